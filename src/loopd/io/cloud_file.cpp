#include "loopd/io/cloud_file.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <fstream>

#include "loopd/io/file_bytes.hpp"
#include "loopd/io/pcd_format.hpp"
#include "loopd/io/ply_format.hpp"

namespace loopd {

std::string lower_extension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos || path.find('/', dot) != std::string::npos) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

namespace {

CloudFile failed(std::string error) {
  CloudFile f;
  f.error = std::move(error);
  return f;
}
}  // namespace

CloudFile parse_kitti_bin(const std::string& bytes, const std::string& source) {
  CloudFile f;
  if (bytes.size() % 16 != 0) {
    f.error = source + ": byte offset " + std::to_string(bytes.size() - bytes.size() % 16) + ": size " + std::to_string(bytes.size()) +
              " is not a multiple of 16 bytes (float32 x, y, z, intensity a point; " + std::to_string(bytes.size() % 16) + " bytes left over)";
    return f;
  }
  const std::size_t n = bytes.size() / 16;  // the file's own size: nothing larger is allocated
  f.cloud.points.resize(n);
  f.cloud.intensity.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    float v[4];
    std::memcpy(v, bytes.data() + 16 * i, sizeof(v));
    f.cloud.points[i] = Eigen::Vector3f(v[0], v[1], v[2]);
    f.cloud.intensity[i] = v[3];
  }
  f.ok = true;
  return f;
}

CloudFile read_kitti_bin(const std::string& path) {
  const FileBytes file = read_file_bytes(path);
  if (!file.ok) return failed(file.error);
  return parse_kitti_bin(file.bytes, path);
}

std::optional<std::string> write_kitti_bin(const std::string& path, const PointCloud& cloud) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return "cannot write " + path;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const float v[4] = {cloud.points[i].x(), cloud.points[i].y(), cloud.points[i].z(), cloud.has_intensity() ? cloud.intensity[i] : 0.f};
    out.write(reinterpret_cast<const char*>(v), sizeof(v));
  }
  if (!out) return path + ": write failed";
  return std::nullopt;
}

CloudFile parse_cloud_bytes(const std::string& bytes, const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == "bin") return parse_kitti_bin(bytes, path);
  if (ext == "pcd") return parse_pcd(bytes, path);
  if (ext == "ply") return parse_ply(bytes, path);
  return failed(path + ": unknown point cloud format '." + ext + "' (expected .bin, .pcd or .ply)");
}

CloudFile read_cloud_file(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext != "bin" && ext != "pcd" && ext != "ply") return failed(path + ": unknown point cloud format '." + ext + "' (expected .bin, .pcd or .ply)");
  const FileBytes file = read_file_bytes(path);
  if (!file.ok) return failed(file.error);
  return parse_cloud_bytes(file.bytes, path);
}

}  // namespace loopd
