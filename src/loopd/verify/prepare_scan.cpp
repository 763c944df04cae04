#include "loopd/verify/prepare_scan.hpp"

#include "loopd/core/cloud_ops.hpp"
#include "loopd/core/stopwatch.hpp"
#include "loopd/registration/gicp.hpp"

#include <algorithm>
#include <cmath>

namespace loopd {

std::size_t PreparedScan::bytes() const {
  return sizeof(PreparedScan) + points.capacity() * sizeof(Eigen::Vector3f) + normals.capacity() * sizeof(PackedNormal) + error.capacity() +
         segmentation.bytes() - sizeof(Segmentation);
}

std::vector<Eigen::Vector3f> PreparedScan::unpacked_normals() const {
  std::vector<Eigen::Vector3f> out;
  if (normals.size() != points.size()) return out;
  out.reserve(normals.size());
  for (const auto& n : normals) {
    const Eigen::Vector3f v(n.x, n.y, n.z);
    const float len = v.norm();
    out.push_back(len > 0.f ? Eigen::Vector3f(v / len) : Eigen::Vector3f::Zero());
  }
  return out;
}

std::optional<std::string> PrepareConfig::validate() const {
  if (!(voxel_size > 0.0)) return "PrepareConfig.voxel_size must be positive";
  if (!(min_range >= 0.0) || !(max_range > min_range)) return "PrepareConfig needs 0 <= min_range < max_range";
  if (normal_k_neighbors != 0 && (normal_k_neighbors < 4 || normal_k_neighbors > 64)) return "PrepareConfig.normal_k_neighbors must be 0 or in [4, 64]";
  if (num_threads < 1) return "PrepareConfig.num_threads must be >= 1";
  SegmentationConfig s = segmentation;
  s.min_range = min_range;
  s.max_range = max_range;
  if (auto err = s.validate()) return "PrepareConfig.segmentation: " + *err;
  return std::nullopt;
}

PreparedScan prepare_scan(const PointCloud& scan, const LidarModel* model, const PrepareConfig& config) {
  Stopwatch sw;
  PreparedScan out;
  out.input_points = scan.size();
  if (auto err = config.validate()) {
    out.error = *err;
    return out;
  }
  std::size_t removed = 0;
  const PointCloud finite = remove_non_finite(scan, &removed);
  out.finite_points = finite.size();
  const PointCloud cropped = crop_range(finite, config.min_range, config.max_range);
  if (cropped.empty()) {
    out.error = "no finite points within " + std::to_string(config.min_range) + "-" + std::to_string(config.max_range) + " m (input " +
                std::to_string(scan.size()) + ", non-finite " + std::to_string(removed) + ")";
    out.ms_total = sw.ms();
    return out;
  }
  Stopwatch seg_sw;
  SegmentationConfig seg_cfg = config.segmentation;
  seg_cfg.min_range = config.min_range;
  seg_cfg.max_range = config.max_range;
  out.segmentation = segment(cropped, model, seg_cfg);
  out.ms_segmentation = seg_sw.ms();
  if (!out.segmentation.error.empty()) out.error = "segmentation: " + out.segmentation.error;

  const PointCloud down = voxel_downsample(cropped, config.voxel_size);
  if (config.max_points > 0 && down.size() > config.max_points) {
    // Deterministic stride subsample (voxel order is spatially sorted, so a stride keeps the coverage).
    const double stride = static_cast<double>(down.size()) / static_cast<double>(config.max_points);
    out.points.reserve(config.max_points);
    for (std::size_t k = 0; k < config.max_points; ++k) out.points.push_back(down.points[static_cast<std::size_t>(static_cast<double>(k) * stride)]);
  } else {
    out.points = down.points;
  }
  out.points.shrink_to_fit();
  if (config.normal_k_neighbors > 0) {
    const std::vector<Eigen::Vector3f> normals = estimate_gicp_normals(out.points, config.normal_k_neighbors, config.num_threads);
    out.normals.reserve(normals.size());
    for (const auto& n : normals) {
      PackedNormal p;
      p.x = static_cast<std::int8_t>(std::lround(std::clamp(n.x(), -1.f, 1.f) * 127.f));
      p.y = static_cast<std::int8_t>(std::lround(std::clamp(n.y(), -1.f, 1.f) * 127.f));
      p.z = static_cast<std::int8_t>(std::lround(std::clamp(n.z(), -1.f, 1.f) * 127.f));
      out.normals.push_back(p);
    }
  }
  out.ms_total = sw.ms();
  return out;
}

}  // namespace loopd
