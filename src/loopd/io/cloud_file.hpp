#pragma once
#include <string>

#include "loopd/core/point_cloud.hpp"

namespace loopd {

/// @brief Reads a point cloud file: KITTI `.bin` (float32 x, y, z, intensity), `.pcd` or `.ply` (loopd's own
///        bounds-checked parsers, see pcd_format.hpp / ply_format.hpp; PCL's readers are not given untrusted
///        files). NaN and Inf points are kept (callers filter). Returns false with a message that names the file
///        and the position (line or byte offset) in `error` on failure; never throws.
bool read_cloud_file(const std::string& path, PointCloud* cloud, std::string* error);

/// @brief Parses cloud file bytes already in memory; `path` picks the format by its extension and names the source
///        in errors.
bool parse_cloud_bytes(const std::string& bytes, const std::string& path, PointCloud* cloud, std::string* error);

/// @brief Reads a KITTI velodyne `.bin` file.
bool read_kitti_bin(const std::string& path, PointCloud* cloud, std::string* error);
/// @brief Parses KITTI `.bin` bytes (a multiple of 16: float32 x, y, z, intensity a point).
bool parse_kitti_bin(const std::string& bytes, const std::string& source, PointCloud* cloud, std::string* error);
/// @brief Writes a KITTI velodyne `.bin` file (intensity 0 where missing).
bool write_kitti_bin(const std::string& path, const PointCloud& cloud, std::string* error);

}  // namespace loopd
