#include "loopd/io/pcl/pcl_cloud_file.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <fstream>

namespace loopd {

bool read_pcl_cloud_file(const std::string& path, PointCloud* cloud, std::string* error) {
  if (!std::ifstream(path)) {
    *error = "cannot open " + path;
    return false;
  }
  pcl::PCLPointCloud2 blob;
  const bool is_ply = path.size() >= 4 && (path.substr(path.size() - 4) == ".ply" || path.substr(path.size() - 4) == ".PLY");
  const int rc = is_ply ? pcl::PLYReader().read(path, blob) : pcl::PCDReader().read(path, blob);
  if (rc < 0) {
    *error = path + ": PCL could not parse the file";
    return false;
  }
  bool has_intensity = false;
  for (const auto& f : blob.fields) has_intensity |= (f.name == "intensity");
  *cloud = PointCloud();
  if (has_intensity) {
    pcl::PointCloud<pcl::PointXYZI> pc;
    pcl::fromPCLPointCloud2(blob, pc);
    cloud->points.reserve(pc.size());
    for (const auto& p : pc) {
      cloud->points.emplace_back(p.x, p.y, p.z);
      cloud->intensity.push_back(p.intensity);
    }
  } else {
    pcl::PointCloud<pcl::PointXYZ> pc;
    pcl::fromPCLPointCloud2(blob, pc);
    cloud->points.reserve(pc.size());
    for (const auto& p : pc) cloud->points.emplace_back(p.x, p.y, p.z);
  }
  return true;
}

}  // namespace loopd
