#include "loopd/io/pcl/pcl_cloud_file.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include "loopd/io/file_bytes.hpp"
#include "loopd/io/pcd_format.hpp"
#include "loopd/io/ply_format.hpp"

namespace loopd {
namespace {
CloudFile failed(std::string error) {
  CloudFile f;
  f.error = std::move(error);
  return f;
}
}  // namespace

CloudFile read_pcl_cloud_file(const std::string& path) {
  // PCL's readers size their buffers from the header before checking that the data are there (a PCD header that
  // declares 2^31 points makes them allocate gigabytes): the file is checked by loopd's own parser first.
  const bool is_ply = path.size() >= 4 && (path.substr(path.size() - 4) == ".ply" || path.substr(path.size() - 4) == ".PLY");
  {
    const FileBytes file = read_file_bytes(path);
    if (!file.ok) return failed(file.error);
    CloudFile own = is_ply ? parse_ply(file.bytes, path) : parse_pcd(file.bytes, path);
    if (!own.ok) return own;
  }
  pcl::PCLPointCloud2 blob;
  const int rc = is_ply ? pcl::PLYReader().read(path, blob) : pcl::PCDReader().read(path, blob);
  if (rc < 0) return failed(path + ": PCL could not parse the file");
  bool has_intensity = false;
  for (const auto& f : blob.fields) has_intensity |= (f.name == "intensity");
  CloudFile result;
  PointCloud* cloud = &result.cloud;
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
  result.ok = true;
  return result;
}

}  // namespace loopd
