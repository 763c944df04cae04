#pragma once
#include <string>

#include "loopd/core/point_cloud.hpp"

namespace loopd {

/// @brief Reads a point cloud file: KITTI `.bin` (float32 x, y, z, intensity), `.pcd` or `.ply` (through PCL).
///        NaN points are kept (callers filter). Returns false with a message in `error` on failure.
bool read_cloud_file(const std::string& path, PointCloud* cloud, std::string* error);

/// @brief Reads a KITTI velodyne `.bin` file.
bool read_kitti_bin(const std::string& path, PointCloud* cloud, std::string* error);
/// @brief Writes a KITTI velodyne `.bin` file (intensity 0 where missing).
bool write_kitti_bin(const std::string& path, const PointCloud& cloud, std::string* error);

}  // namespace loopd
