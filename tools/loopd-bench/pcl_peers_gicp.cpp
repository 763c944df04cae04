// The only translation unit with PCL headers for the GICP peer (see pcl_peers_gicp.hpp).
#include "pcl_peers_gicp.hpp"

#include "loopd/base/stopwatch.hpp"

#ifdef LOOPD_WITH_PCL
#include <pcl/registration/gicp.h>

#include "pcl_peers_common.hpp"
#endif

namespace loopd::bench {

PclGicpResult pcl_gicp_align(const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& target, const Eigen::Isometry3d& init,
                             double max_correspondence_distance, int max_iterations, int k_neighbors) {
  PclGicpResult r;
#ifdef LOOPD_WITH_PCL
  r.available = true;
  const auto src = to_pcl_cloud(source);
  const auto tgt = to_pcl_cloud(target);
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
  r.T_target_source = isometry_from_pcl(gicp.getFinalTransformation());
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
