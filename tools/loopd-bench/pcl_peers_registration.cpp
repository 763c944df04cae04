// The only translation unit with PCL headers for the 4PCS peers (see pcl_peers_registration.hpp).
#include "pcl_peers_registration.hpp"

#include <ctime>

#include "loopd/base/stopwatch.hpp"

#ifdef LOOPD_WITH_PCL
#include <pcl/registration/ia_fpcs.h>
#include <pcl/registration/ia_kfpcs.h>

#include "pcl_peers_common.hpp"
#endif

namespace loopd::bench {
namespace {
double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}
}  // namespace

PclFpcsResult pcl_fpcs_align(PclFpcsVariant variant, const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& target,
                             const PclFpcsConfig& config) {
  PclFpcsResult r;
#ifdef LOOPD_WITH_PCL
  r.available = true;
  const auto src = to_pcl_cloud(source);
  const auto tgt = to_pcl_cloud(target);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  Eigen::Matrix4f T = Eigen::Matrix4f::Identity();
  const double cpu0 = thread_cpu_ms();
  Stopwatch sw;
  if (variant == PclFpcsVariant::kFpcs) {
    pcl::registration::FPCSInitialAlignment<pcl::PointXYZ, pcl::PointXYZ> fpcs;
    fpcs.setInputSource(src);
    fpcs.setInputTarget(tgt);
    fpcs.setDelta(config.delta, false);
    fpcs.setApproxOverlap(config.approx_overlap);
    fpcs.setNumberOfSamples(config.nr_samples);
    fpcs.setMaxComputationTime(config.max_seconds);
    fpcs.setNumberOfThreads(config.num_threads);
    fpcs.align(aligned);
    r.converged = fpcs.hasConverged();
    T = fpcs.getFinalTransformation();
  } else {
    // KFPCS expects sparse keypoints as input (the caller passes a coarse voxel grid) and an absolute delta.
    pcl::registration::KFPCSInitialAlignment<pcl::PointXYZ, pcl::PointXYZ> kfpcs;
    kfpcs.setInputSource(src);
    kfpcs.setInputTarget(tgt);
    kfpcs.setDelta(config.delta, false);
    kfpcs.setApproxOverlap(config.approx_overlap);
    kfpcs.setMaxComputationTime(config.max_seconds);
    kfpcs.setNumberOfThreads(config.num_threads);
    kfpcs.align(aligned);
    r.converged = kfpcs.hasConverged();
    T = kfpcs.getFinalTransformation();
  }
  r.ms = sw.ms();
  r.cpu_ms = thread_cpu_ms() - cpu0;
  r.T_target_source = isometry_from_pcl(T);
#else
  (void)variant;
  (void)source;
  (void)target;
  (void)config;
#endif
  return r;
}

}  // namespace loopd::bench
