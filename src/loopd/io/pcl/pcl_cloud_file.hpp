#pragma once
#include <string>

#include "loopd/base/point_cloud.hpp"
#include "loopd/io/cloud_file.hpp"

namespace loopd {
/// @brief Reads a PCD or PLY file with PCL's readers (x, y, z, and intensity when present), after loopd's own
///        parser (pcd_format.hpp / ply_format.hpp) has accepted it. read_cloud_file does not need PCL; this is the
///        reference the tests compare loopd's parsers with.
CloudFile read_pcl_cloud_file(const std::string& path);
}  // namespace loopd
