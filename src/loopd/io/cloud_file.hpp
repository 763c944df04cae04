#pragma once
#include <optional>
#include <string>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief A point cloud read from a file, or ok == false (cloud empty: nothing half-read is handed out) with a message
///        that names the file and the position (line or byte offset).
struct CloudFile {
  PointCloud cloud;
  bool ok = false;
  std::string error;
};

/// @brief Reads a point cloud file: KITTI `.bin` (float32 x, y, z, intensity), `.pcd` or `.ply` (loopd's own
///        bounds-checked parsers, see pcd_format.hpp / ply_format.hpp; PCL's readers are not given untrusted
///        files). NaN and Inf points are kept (callers filter). Never throws.
CloudFile read_cloud_file(const std::string& path);

/// @brief Parses cloud file bytes already in memory; `path` picks the format by its extension and names the source
///        in errors.
CloudFile parse_cloud_bytes(const std::string& bytes, const std::string& path);

/// @brief The extension of `path`'s last component, lower case, without the dot ("" when it has none).
std::string lower_extension(const std::string& path);

/// @brief Reads a KITTI velodyne `.bin` file.
CloudFile read_kitti_bin(const std::string& path);
/// @brief Parses KITTI `.bin` bytes (a multiple of 16: float32 x, y, z, intensity a point).
CloudFile parse_kitti_bin(const std::string& bytes, const std::string& source);
/// @brief Writes a KITTI velodyne `.bin` file (intensity 0 where missing).
/// @return std::nullopt, or "cannot write <path>" / "<path>: write failed".
std::optional<std::string> write_kitti_bin(const std::string& path, const PointCloud& cloud);

}  // namespace loopd
