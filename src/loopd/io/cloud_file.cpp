#include "loopd/io/cloud_file.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <fstream>

#include "loopd/io/file_bytes.hpp"
#include "loopd/io/pcd_format.hpp"
#include "loopd/io/ply_format.hpp"

namespace loopd {
namespace {
std::string lower_extension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos || path.find('/', dot) != std::string::npos) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}
}  // namespace

bool parse_kitti_bin(const std::string& bytes, const std::string& source, PointCloud* cloud, std::string* error) {
  *cloud = PointCloud();
  if (bytes.size() % 16 != 0) {
    *error = source + ": byte offset " + std::to_string(bytes.size() - bytes.size() % 16) + ": size " + std::to_string(bytes.size()) +
             " is not a multiple of 16 bytes (float32 x, y, z, intensity a point; " + std::to_string(bytes.size() % 16) + " bytes left over)";
    return false;
  }
  const std::size_t n = bytes.size() / 16;  // the file's own size: nothing larger is allocated
  cloud->points.resize(n);
  cloud->intensity.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    float v[4];
    std::memcpy(v, bytes.data() + 16 * i, sizeof(v));
    cloud->points[i] = Eigen::Vector3f(v[0], v[1], v[2]);
    cloud->intensity[i] = v[3];
  }
  return true;
}

bool read_kitti_bin(const std::string& path, PointCloud* cloud, std::string* error) {
  *cloud = PointCloud();
  std::string bytes;
  if (!read_file_bytes(path, &bytes, error)) return false;
  return parse_kitti_bin(bytes, path, cloud, error);
}

bool write_kitti_bin(const std::string& path, const PointCloud& cloud, std::string* error) {
  std::ofstream out(path, std::ios::binary);
  if (!out) {
    *error = "cannot write " + path;
    return false;
  }
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const float v[4] = {cloud.points[i].x(), cloud.points[i].y(), cloud.points[i].z(), cloud.has_intensity() ? cloud.intensity[i] : 0.f};
    out.write(reinterpret_cast<const char*>(v), sizeof(v));
  }
  return static_cast<bool>(out);
}

bool parse_cloud_bytes(const std::string& bytes, const std::string& path, PointCloud* cloud, std::string* error) {
  const std::string ext = lower_extension(path);
  if (ext == "bin") return parse_kitti_bin(bytes, path, cloud, error);
  if (ext == "pcd") return parse_pcd(bytes, path, cloud, error);
  if (ext == "ply") return parse_ply(bytes, path, cloud, error);
  *error = path + ": unknown point cloud format '." + ext + "' (expected .bin, .pcd or .ply)";
  return false;
}

bool read_cloud_file(const std::string& path, PointCloud* cloud, std::string* error) {
  *cloud = PointCloud();
  const std::string ext = lower_extension(path);
  if (ext != "bin" && ext != "pcd" && ext != "ply") {
    *error = path + ": unknown point cloud format '." + ext + "' (expected .bin, .pcd or .ply)";
    return false;
  }
  std::string bytes;
  if (!read_file_bytes(path, &bytes, error)) return false;
  return parse_cloud_bytes(bytes, path, cloud, error);
}

}  // namespace loopd
