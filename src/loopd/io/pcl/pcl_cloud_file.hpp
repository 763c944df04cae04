#pragma once
#include <string>

#include "loopd/core/point_cloud.hpp"

namespace loopd {
/// @brief Reads a PCD or PLY file with PCL's readers (x, y, z, and intensity when present).
bool read_pcl_cloud_file(const std::string& path, PointCloud* cloud, std::string* error);
}  // namespace loopd
