#include "loopd/pipeline/prepare_scan.hpp"

#include "loopd/core/cloud_ops.hpp"
#include "loopd/core/stopwatch.hpp"
#include "loopd/registration/gicp.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace loopd {

std::optional<std::string> PrepareConfig::validate() const {
  if (!(voxel_size > 0.0)) return "PrepareConfig.voxel_size must be positive";
  if (!(min_range >= 0.0) || !(max_range > min_range)) return "PrepareConfig needs 0 <= min_range < max_range";
  if (normal_k_neighbors != 0 && (normal_k_neighbors < 4 || normal_k_neighbors > 64)) return "PrepareConfig.normal_k_neighbors must be 0 or in [4, 64]";
  if (num_threads < 1) return "PrepareConfig.num_threads must be >= 1";
  if (!(range_image_normal_coherence >= 0.0 && range_image_normal_coherence <= 1.0)) return "PrepareConfig.range_image_normal_coherence must be in [0, 1]";
  SegmentationConfig s = segmentation;
  s.min_range = min_range;
  s.max_range = max_range;
  if (auto err = s.validate()) return "PrepareConfig.segmentation: " + *err;
  return std::nullopt;
}

namespace {

/// Floor for values well inside the int64 range (voxel coordinates), without a libm call.
inline std::int64_t floor_to_int(double v) {
  const auto t = static_cast<std::int64_t>(v);
  return t - (static_cast<double>(t) > v ? 1 : 0);
}

/// Voxel centroids of the finite points of `points` within [lo2, hi2] squared range, sorted by voxel key: the same
/// output as voxel_downsample(crop_range(remove_non_finite(scan))) (same key, same double sums in index order, same
/// order), fused into one pass without copying the cloud or its attributes. Consecutive lidar returns usually fall in
/// the same voxel, so the last voxel is remembered and the hash probe skipped for them.
/// With `point_normals` (sized like `points`), `voxel_normals` gets the mean of each voxel's non-zero point normals,
/// or zero when their mean is shorter than `coherence`.
std::vector<Eigen::Vector3f> crop_voxel_downsample(const std::vector<Eigen::Vector3f>& points, float lo2, float hi2, double leaf_size,
                                                   const std::vector<Eigen::Vector3f>* point_normals = nullptr, float coherence = 0.f,
                                                   std::vector<Eigen::Vector3f>* voxel_normals = nullptr) {
  const double inv = 1.0 / leaf_size;
  constexpr std::int64_t kOffset = 1 << 20;
  constexpr std::int64_t kLimit = std::int64_t{1} << 21;
  constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::size_t capacity = 16;
  while (capacity < points.size() / 16) capacity <<= 1;  // voxels << points (~1:15 at 0.6 m); grown below when needed
  std::vector<std::uint64_t> slot_key(capacity, kEmpty);
  std::vector<std::uint32_t> slot_voxel(capacity);
  struct Voxel {
    std::uint64_t key;
    Eigen::Vector3d sum;
    std::uint32_t count;
    std::uint32_t normal_count;
    Eigen::Vector3f normal_sum;
  };
  const bool with_normals = point_normals && voxel_normals && point_normals->size() == points.size();
  std::vector<Voxel> voxels;
  voxels.reserve(capacity / 4);
  auto insert_slot = [&](std::uint64_t key, std::uint32_t v) {
    std::size_t h = detail::voxel_slot(key, capacity);
    while (slot_key[h] != kEmpty && slot_key[h] != key) h = (h + 1) & (capacity - 1);
    return h;
  };
  std::uint64_t last_key = kEmpty;
  std::uint32_t last_voxel = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    const float d2 = p.squaredNorm();  // NaN/Inf fail the range test
    if (!(d2 >= lo2 && d2 <= hi2) || !p.allFinite()) continue;
    const std::int64_t x = floor_to_int(p.x() * inv) + kOffset;
    const std::int64_t y = floor_to_int(p.y() * inv) + kOffset;
    const std::int64_t z = floor_to_int(p.z() * inv) + kOffset;
    if (x < 0 || y < 0 || z < 0 || x >= kLimit || y >= kLimit || z >= kLimit) continue;
    const std::uint64_t key = (static_cast<std::uint64_t>(x) << 42) | (static_cast<std::uint64_t>(y) << 21) | static_cast<std::uint64_t>(z);
    if (key != last_key) {
      std::size_t h = insert_slot(key, 0);
      if (slot_key[h] == kEmpty) {
        if (2 * (voxels.size() + 1) > capacity) {  // keep the load factor <= 1/2
          capacity <<= 1;
          slot_key.assign(capacity, kEmpty);
          slot_voxel.resize(capacity);
          for (std::uint32_t v = 0; v < voxels.size(); ++v) {
            const std::size_t hv = insert_slot(voxels[v].key, v);
            slot_key[hv] = voxels[v].key;
            slot_voxel[hv] = v;
          }
          h = insert_slot(key, 0);
        }
        slot_key[h] = key;
        slot_voxel[h] = static_cast<std::uint32_t>(voxels.size());
        voxels.push_back({key, Eigen::Vector3d::Zero(), 0, 0, Eigen::Vector3f::Zero()});
      }
      last_key = key;
      last_voxel = slot_voxel[h];
    }
    Voxel& v = voxels[last_voxel];
    v.sum += p.cast<double>();
    ++v.count;
    if (with_normals) {
      const Eigen::Vector3f& n = (*point_normals)[i];
      if (!n.isZero()) {
        v.normal_sum += n;
        ++v.normal_count;
      }
    }
  }
  std::sort(voxels.begin(), voxels.end(), [](const Voxel& a, const Voxel& b) { return a.key < b.key; });
  std::vector<Eigen::Vector3f> out;
  out.reserve(voxels.size());
  for (const Voxel& v : voxels) out.push_back((v.sum / static_cast<double>(v.count)).cast<float>());
  if (with_normals) {
    voxel_normals->assign(voxels.size(), Eigen::Vector3f::Zero());
    for (std::size_t k = 0; k < voxels.size(); ++k) {
      const Voxel& v = voxels[k];
      if (v.normal_count == 0) continue;
      const float len = v.normal_sum.norm();
      if (len >= coherence * static_cast<float>(v.normal_count) && len > 0.f) (*voxel_normals)[k] = v.normal_sum / len;
    }
  }
  return out;
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
  // One counting pass instead of two filtered copies of the cloud: segment() applies the same finite and range
  // tests itself, and the voxel grid below reads the scan directly.
  const float lo2 = static_cast<float>(config.min_range * config.min_range), hi2 = static_cast<float>(config.max_range * config.max_range);
  std::size_t finite = 0, in_range = 0;
  for (const Eigen::Vector3f& p : scan.points) {
    if (!p.allFinite()) continue;
    ++finite;
    const float d2 = p.squaredNorm();
    in_range += (d2 >= lo2 && d2 <= hi2) ? 1 : 0;
  }
  const std::size_t removed = scan.size() - finite;
  out.finite_points = finite;
  if (in_range == 0) {
    out.error = "no finite points within " + std::to_string(config.min_range) + "-" + std::to_string(config.max_range) + " m (input " +
                std::to_string(scan.size()) + ", non-finite " + std::to_string(removed) + ")";
    out.ms_total = sw.ms();
    return out;
  }
  Stopwatch seg_sw;
  const bool range_normals = config.normal_k_neighbors > 0 && config.range_image_normal_coherence > 0.0;
  std::vector<Eigen::Vector3f> point_normals;
  SegmentationConfig seg_cfg = config.segmentation;
  seg_cfg.min_range = config.min_range;
  seg_cfg.max_range = config.max_range;
  if (in_range < static_cast<std::size_t>(std::max(seg_cfg.min_cluster_points, 0))) {
    out.segmentation.error = "too few points to segment";  // what segment() says for the cropped cloud
  } else {
    out.segmentation = segment(scan, model, seg_cfg, range_normals ? &point_normals : nullptr);
  }
  out.ms_segmentation = seg_sw.ms();
  if (!out.segmentation.error.empty()) out.error = "segmentation: " + out.segmentation.error;

  const bool have_range_normals = range_normals && out.segmentation.error.empty() && point_normals.size() == scan.size();
  std::vector<Eigen::Vector3f> voxel_normals;
  std::vector<Eigen::Vector3f> down =
      crop_voxel_downsample(scan.points, lo2, hi2, config.voxel_size, have_range_normals ? &point_normals : nullptr,
                            static_cast<float>(config.range_image_normal_coherence), &voxel_normals);
  point_normals = {};
  std::vector<Eigen::Vector3f> kept_normals;
  if (config.max_points > 0 && down.size() > config.max_points) {
    // Deterministic stride subsample (voxel order is spatially sorted, so a stride keeps the coverage).
    const double stride = static_cast<double>(down.size()) / static_cast<double>(config.max_points);
    out.points.reserve(config.max_points);
    for (std::size_t k = 0; k < config.max_points; ++k) {
      const auto i = static_cast<std::size_t>(static_cast<double>(k) * stride);
      out.points.push_back(down[i]);
      if (have_range_normals) kept_normals.push_back(voxel_normals[i]);
    }
  } else {
    out.points = std::move(down);
    kept_normals = std::move(voxel_normals);
  }
  out.points.shrink_to_fit();
  if (config.normal_k_neighbors > 0) {
    const std::vector<Eigen::Vector3f> normals =
        have_range_normals ? std::move(kept_normals) : estimate_gicp_normals(out.points, config.normal_k_neighbors, config.num_threads);
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
