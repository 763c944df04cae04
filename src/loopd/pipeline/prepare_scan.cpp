#include "loopd/pipeline/prepare_scan.hpp"

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/stopwatch.hpp"
#include "loopd/base/voxel_grid.hpp"
#include "loopd/registration/gicp.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

namespace loopd {

std::optional<std::string> PrepareConfig::validate() const {
  if (!(voxel_size > 0.0)) return "PrepareConfig.voxel_size must be positive";
  if (!(min_range >= 0.0) || !(max_range > min_range)) return "PrepareConfig needs 0 <= min_range < max_range";
  if (normal_k_neighbors != 0 && (normal_k_neighbors < 4 || normal_k_neighbors > 64))
    return "PrepareConfig.normal_k_neighbors must be 0 or in [4, 64]";
  if (num_threads < 1) return "PrepareConfig.num_threads must be >= 1";
  if (!(range_image_normal_coherence >= 0.0 && range_image_normal_coherence <= 1.0))
    return "PrepareConfig.range_image_normal_coherence must be in [0, 1]";
  SegmentationConfig s = segmentation;
  s.min_range = min_range;
  s.max_range = max_range;
  if (auto err = s.validate()) return "PrepareConfig.segmentation: " + *err;
  return std::nullopt;
}

namespace {

/// @brief Per-voxel sum of the non-zero point normals (prepare_scan's range-image normals).
struct NormalSum {
  std::uint32_t count = 0;
  Eigen::Vector3f sum = Eigen::Vector3f::Zero();
};

/// @brief Finite points of a scan and those of them within the crop range.
struct PointCounts {
  std::size_t finite = 0;
  std::size_t in_range = 0;
};

/// One counting pass instead of two filtered copies of the cloud: segment() applies the same finite and range
/// tests itself, and the voxel grid reads the scan directly.
PointCounts count_points(const std::vector<Eigen::Vector3f>& points, float lo2, float hi2) {
  PointCounts n;
  for (const Eigen::Vector3f& p : points) {
    if (!p.allFinite()) continue;
    ++n.finite;
    const float d2 = p.squaredNorm();
    n.in_range += (d2 >= lo2 && d2 <= hi2) ? 1 : 0;
  }
  return n;
}

/// Voxel centroids of the finite points of `points` within [lo2, hi2] squared range, sorted by voxel key: the same
/// output as voxel_downsample(crop_range(remove_non_finite(scan))) (the same VoxelGrid, fed the same points in the
/// same order), fused into one pass without copying the cloud or its attributes.
/// With `point_normals` (sized like `points`), `voxel_normals` gets the mean of each voxel's non-zero point normals,
/// or zero when their mean is shorter than `coherence`.
std::vector<Eigen::Vector3f> crop_voxel_downsample(const std::vector<Eigen::Vector3f>& points, float lo2, float hi2, double leaf_size,
                                                   const std::vector<Eigen::Vector3f>* point_normals = nullptr, float coherence = 0.f,
                                                   std::vector<Eigen::Vector3f>* voxel_normals = nullptr) {
  const bool with_normals = point_normals && voxel_normals && point_normals->size() == points.size();
  VoxelGrid<NormalSum> grid(leaf_size, points.size() / 32);  // voxels << points (~1:15 at 0.6 m); the grid grows when needed
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    const float d2 = p.squaredNorm();  // NaN/Inf fail the range test
    if (!(d2 >= lo2 && d2 <= hi2) || !p.allFinite()) continue;
    auto* v = grid.add(p);
    if (v == nullptr || !with_normals) continue;
    const Eigen::Vector3f& n = (*point_normals)[i];
    if (!n.isZero()) {
      v->payload.sum += n;
      ++v->payload.count;
    }
  }
  const auto voxels = std::move(grid).sorted_voxels();
  std::vector<Eigen::Vector3f> out;
  out.reserve(voxels.size());
  for (const auto& v : voxels) out.push_back(v.centroid());
  if (with_normals) {
    voxel_normals->assign(voxels.size(), Eigen::Vector3f::Zero());
    for (std::size_t k = 0; k < voxels.size(); ++k) {
      const NormalSum& n = voxels[k].payload;
      if (n.count == 0) continue;
      const float len = n.sum.norm();
      if (len >= coherence * static_cast<float>(n.count) && len > 0.f) (*voxel_normals)[k] = n.sum / len;
    }
  }
  return out;
}

/// Vlaminck 2019, Sec. 4.2.1: segments the full-resolution scan (cropped by segment() itself) into `out`; fills
/// `point_normals` when given. A scan with fewer in-range points than a cluster needs is not segmented.
void segment_scan(const PointCloud& scan, const LidarModel* model, const PrepareConfig& config, std::size_t in_range,
                  std::vector<Eigen::Vector3f>* point_normals, PreparedScan* out) {
  Stopwatch seg_sw;
  SegmentationConfig seg_cfg = config.segmentation;
  seg_cfg.min_range = config.min_range;
  seg_cfg.max_range = config.max_range;
  if (in_range < static_cast<std::size_t>(std::max(seg_cfg.min_cluster_points, 0))) {
    out->segmentation.error = "too few points to segment";  // what segment() says for the cropped cloud
  } else {
    out->segmentation = segment(scan, model, seg_cfg, point_normals);
  }
  out->ms_segmentation = seg_sw.ms();
  if (!out->segmentation.error.empty()) out->error = "segmentation: " + out->segmentation.error;
}

/// Keeps at most `max_points` of `down` (0: all) in `points`, with their `voxel_normals` when `with_normals`:
/// a deterministic stride subsample (voxel order is spatially sorted, so a stride keeps the coverage).
void cap_points(std::vector<Eigen::Vector3f> down, std::vector<Eigen::Vector3f> voxel_normals, bool with_normals, std::size_t max_points,
                std::vector<Eigen::Vector3f>* points, std::vector<Eigen::Vector3f>* kept_normals) {
  if (max_points > 0 && down.size() > max_points) {
    const double stride = static_cast<double>(down.size()) / static_cast<double>(max_points);
    points->reserve(max_points);
    for (std::size_t k = 0; k < max_points; ++k) {
      const auto i = static_cast<std::size_t>(static_cast<double>(k) * stride);
      points->push_back(down[i]);
      if (with_normals) kept_normals->push_back(voxel_normals[i]);
    }
  } else {
    *points = std::move(down);
    *kept_normals = std::move(voxel_normals);
  }
  points->shrink_to_fit();
}

/// A unit normal quantised to int8 per axis (value * 127).
PackedNormal pack_normal(const Eigen::Vector3f& n) {
  PackedNormal p;
  p.x = static_cast<std::int8_t>(std::lround(std::clamp(n.x(), -1.f, 1.f) * 127.f));
  p.y = static_cast<std::int8_t>(std::lround(std::clamp(n.y(), -1.f, 1.f) * 127.f));
  p.z = static_cast<std::int8_t>(std::lround(std::clamp(n.z(), -1.f, 1.f) * 127.f));
  return p;
}

}  // namespace

PreparedScan prepare_scan(const PointCloud& scan, const LidarModel* model, const PrepareConfig& config) {
  Stopwatch sw;
  PreparedScan out;
  out.input_points = scan.size();
  if (auto err = config.validate()) {
    out.error = *err;
    return out;
  }
  const float lo2 = static_cast<float>(config.min_range * config.min_range), hi2 = static_cast<float>(config.max_range * config.max_range);
  const PointCounts counts = count_points(scan.points, lo2, hi2);
  const std::size_t removed = scan.size() - counts.finite;
  out.finite_points = counts.finite;
  if (counts.in_range == 0) {
    out.error = "no finite points within " + std::to_string(config.min_range) + "-" + std::to_string(config.max_range) + " m (input " +
                std::to_string(scan.size()) + ", non-finite " + std::to_string(removed) + ")";
    out.ms_total = sw.ms();
    return out;
  }
  // Segmentation of the full-resolution scan; its range-image normals become the cached GICP normals.
  const bool range_normals = config.normal_k_neighbors > 0 && config.range_image_normal_coherence > 0.0;
  std::vector<Eigen::Vector3f> point_normals;
  segment_scan(scan, model, config, counts.in_range, range_normals ? &point_normals : nullptr, &out);

  // Voxel cloud (and per-voxel mean normals), capped at max_points.
  const bool have_range_normals = range_normals && out.segmentation.error.empty() && point_normals.size() == scan.size();
  std::vector<Eigen::Vector3f> voxel_normals;
  std::vector<Eigen::Vector3f> down = crop_voxel_downsample(scan.points, lo2, hi2, config.voxel_size, have_range_normals ? &point_normals : nullptr,
                                                            static_cast<float>(config.range_image_normal_coherence), &voxel_normals);
  point_normals = {};
  std::vector<Eigen::Vector3f> kept_normals;
  cap_points(std::move(down), std::move(voxel_normals), have_range_normals, config.max_points, &out.points, &kept_normals);

  // Cached GICP normals: from the range image, else PCA of the nearest voxel centroids (Ren 2019, Eq. 2).
  if (config.normal_k_neighbors > 0) {
    const std::vector<Eigen::Vector3f> normals =
        have_range_normals ? std::move(kept_normals) : estimate_gicp_normals(out.points, config.normal_k_neighbors, config.num_threads);
    out.normals.reserve(normals.size());
    for (const auto& n : normals) out.normals.push_back(pack_normal(n));
  }
  out.ms_total = sw.ms();
  return out;
}

}  // namespace loopd
