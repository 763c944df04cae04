#include "loopd/store/map_cloud.hpp"

#include <cmath>

#include "loopd/base/cloud_ops.hpp"

namespace loopd {

std::optional<std::string> MapCloudConfig::validate() const {
  if (!(voxel >= 0.02 && voxel <= 2.0)) return "map.cloud_voxel must be in [0.02, 2] m";
  if (!(min_range >= 0.0) || !(max_range > min_range) || !std::isfinite(max_range) || max_range > 300.0)
    return "map.cloud_min_range / cloud_max_range: need 0 <= min < max <= 300 m";
  if (!(quantum >= 0.001 && quantum <= voxel)) return "map.cloud_quantum must be in [0.001 m, cloud_voxel]";
  if (zstd_level < 1 || zstd_level > 19) return "map.cloud_zstd_level must be in [1, 19]";
  return std::nullopt;
}

PointCloud reduce_to_map_cloud(const PointCloud& scan, const MapCloudConfig& config) {
  PointCloud finite = remove_non_finite(scan);
  finite.time.clear();
  finite.ring.clear();
  finite.num_rings = 0;
  return voxel_downsample(crop_range(finite, config.min_range, config.max_range), config.voxel);
}

}  // namespace loopd
