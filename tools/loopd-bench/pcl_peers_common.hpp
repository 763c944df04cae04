#pragma once
// Conversions shared by the PCL peer translation units (pcl_peers_gicp.cpp, pcl_peers_registration.cpp). Include it
// ONLY from those files: it pulls in PCL headers, which stay out of the rest of loopd-bench.
#ifdef LOOPD_WITH_PCL
#include <Eigen/Geometry>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <vector>

namespace loopd::bench {

/// @brief Points [m] to a new PCL XYZ cloud (same order).
inline pcl::PointCloud<pcl::PointXYZ>::Ptr to_pcl_cloud(const std::vector<Eigen::Vector3f>& points) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr c(new pcl::PointCloud<pcl::PointXYZ>);
  c->reserve(points.size());
  for (const auto& p : points) c->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return c;
}

/// @brief PCL's float 4x4 result as an isometry, the rotation re-orthonormalised.
inline Eigen::Isometry3d isometry_from_pcl(const Eigen::Matrix4f& T) {
  Eigen::Isometry3d out;
  out.matrix() = T.cast<double>();
  out.linear() = Eigen::Quaterniond(Eigen::Matrix3d(out.linear())).normalized().toRotationMatrix();
  return out;
}

}  // namespace loopd::bench
#endif
