// The only translation unit with PCL headers for the GICP peer (see pcl_peers_gicp.hpp).
#include "pcl_peers_gicp.hpp"

#include "loopd/core/stopwatch.hpp"

#ifdef LOOPD_WITH_PCL
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>
#endif

namespace loopd::bench {

PclGicpResult pcl_gicp_align(const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& target, const Eigen::Isometry3d& init,
                             double max_correspondence_distance, int max_iterations, int k_neighbors) {
  PclGicpResult r;
#ifdef LOOPD_WITH_PCL
  r.available = true;
  auto to_pcl = [](const std::vector<Eigen::Vector3f>& pts) {
    pcl::PointCloud<pcl::PointXYZ>::Ptr c(new pcl::PointCloud<pcl::PointXYZ>);
    c->reserve(pts.size());
    for (const auto& p : pts) c->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    return c;
  };
  const auto src = to_pcl(source);
  const auto tgt = to_pcl(target);
  Stopwatch sw;
  pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
  gicp.setCorrespondenceRandomness(k_neighbors);
  gicp.setMaxCorrespondenceDistance(max_correspondence_distance);
  gicp.setMaximumIterations(max_iterations);
  gicp.setTransformationEpsilon(1e-6);
  gicp.setInputSource(src);
  gicp.setInputTarget(tgt);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  gicp.align(aligned, init.matrix().cast<float>());
  r.ms = sw.ms();
  r.converged = gicp.hasConverged();
  r.T_target_source.matrix() = gicp.getFinalTransformation().cast<double>();
  // Re-orthonormalise the float rotation.
  r.T_target_source.linear() = Eigen::Quaterniond(r.T_target_source.linear()).normalized().toRotationMatrix();
#else
  (void)source;
  (void)target;
  (void)init;
  (void)max_correspondence_distance;
  (void)max_iterations;
  (void)k_neighbors;
#endif
  return r;
}

}  // namespace loopd::bench
