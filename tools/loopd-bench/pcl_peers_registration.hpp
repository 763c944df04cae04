#pragma once
// PCL's FPCSInitialAlignment and KFPCSInitialAlignment as benchmark peers of loopd's plane-based 4PCS.
// No PCL types in this header: pcl_peers_registration.cpp is the only translation unit with those PCL headers.
#include <Eigen/Geometry>
#include <vector>

namespace loopd::bench {

enum class PclFpcsVariant { kFpcs, kKfpcs };

/// @brief Settings shared by both peers, chosen to match loopd's 4PCS (same delta, overlap for same-place pairs).
struct PclFpcsConfig {
  float delta = 0.5f;           ///< [m] same as loopd's LCP delta (not normalised by point density)
  float approx_overlap = 0.7f;  ///< revisits of the same place overlap strongly
  int nr_samples = 500;         ///< FPCS: source points used to score a candidate (like loopd's LCP sample)
  int max_seconds = 2;          ///< hard cap per pair (PCL's setMaxComputationTime, whole seconds)
  int num_threads = 1;          ///< same thread count as loopd in the benchmark
};

struct PclFpcsResult {
  bool available = false;  ///< false when built without PCL
  bool converged = false;
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  double ms = 0;      ///< [ms] wall time of align()
  double cpu_ms = 0;  ///< [ms] CPU time of align() on the calling thread
};

/// @brief Global alignment of `source` onto `target` with pcl::registration::(K)FPCSInitialAlignment<PointXYZ>.
/// @note PCL seeds std::rand with time() inside align(): runs are not repeatable (no seed in its API).
PclFpcsResult pcl_fpcs_align(PclFpcsVariant variant, const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& target,
                             const PclFpcsConfig& config);

}  // namespace loopd::bench
