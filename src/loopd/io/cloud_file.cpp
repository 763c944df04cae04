#include "loopd/io/cloud_file.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>

#ifdef LOOPD_WITH_PCL
#include "loopd/io/pcl/pcl_cloud_file.hpp"
#endif

namespace loopd {
namespace {
std::string lower_extension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}
}  // namespace

bool read_kitti_bin(const std::string& path, PointCloud* cloud, std::string* error) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) {
    *error = "cannot open " + path;
    return false;
  }
  const std::streamsize bytes = in.tellg();
  if (bytes % 16 != 0) {
    *error = path + ": size " + std::to_string(bytes) + " is not a multiple of 16 bytes (float32 x, y, z, intensity)";
    return false;
  }
  in.seekg(0);
  std::vector<float> raw(static_cast<std::size_t>(bytes / 4));
  if (!in.read(reinterpret_cast<char*>(raw.data()), bytes)) {
    *error = "cannot read " + path;
    return false;
  }
  const std::size_t n = raw.size() / 4;
  *cloud = PointCloud();
  cloud->points.resize(n);
  cloud->intensity.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    cloud->points[i] = Eigen::Vector3f(raw[4 * i], raw[4 * i + 1], raw[4 * i + 2]);
    cloud->intensity[i] = raw[4 * i + 3];
  }
  return true;
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

bool read_cloud_file(const std::string& path, PointCloud* cloud, std::string* error) {
  const std::string ext = lower_extension(path);
  if (ext == "bin") return read_kitti_bin(path, cloud, error);
  if (ext == "pcd" || ext == "ply") {
#ifdef LOOPD_WITH_PCL
    return read_pcl_cloud_file(path, cloud, error);
#else
    *error = path + ": PCD/PLY support was not built (LOOPD_WITH_PCL=OFF)";
    return false;
#endif
  }
  *error = path + ": unknown point cloud format '." + ext + "' (expected .bin, .pcd or .ply)";
  return false;
}

}  // namespace loopd
