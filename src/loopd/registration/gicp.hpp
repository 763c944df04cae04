#pragma once
/// @file Generalized ICP (plane-to-plane) for loop refinement (Ren 2019, Sec. 3.2; Segal 2009).
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

namespace loopd {

/// @brief Settings of align_gicp. Defaults are tuned for loop closure on clouds voxel-downsampled to ~0.6 m
/// (see pipeline/prepare_scan.hpp for the voxel-size rationale).
struct GicpConfig {
  int k_neighbors = 20;    ///< neighbours for each point's covariance (Ren 2019, Eq. 2)
  double epsilon = 0.001;  ///< smallest eigenvalue of the normalised covariance, diag(eps, 1, 1) (Ren 2019, Eq. 3)
  /// [m] correspondence distance schedule: one Gauss-Newton stage per entry, coarse to fine. The last entry is also the
  /// distance used for the reported residual and fitness.
  std::vector<double> max_correspondence_distances{2.0, 1.0, 0.6};
  int max_iterations = 20;                ///< Gauss-Newton iterations per stage
  double convergence_translation = 1e-3;  ///< [m] a stage stops when the update is below this ...
  double convergence_rotation = 1e-4;     ///< [rad] ... and this
  double damping = 1e-6;                  ///< Levenberg-style damping, relative to the largest diagonal entry of H
  /// Below this inlier fraction the result is reported as not converged (a local minimum far from the truth, e.g.
  /// started 90 deg off, still satisfies the step criterion; fitness is what tells it apart).
  double min_fitness = 0.3;
  /// Source points used in the optimisation (deterministic stride subsample beyond it; 0: all). Their normals still
  /// come from the full source. Halves the per-iteration work on a 6k-point keyframe at no measurable accuracy cost
  /// (loopd-bench gicp); fitness, residual and H refer to the used points.
  int max_source_points = 2500;
  /// OpenMP threads; the result does not depend on it (fixed-block reduction).
  /// @note On an oversubscribed machine libgomp's default active wait burns the CPU the other thread needs (measured
  /// on the shared 2-core box: 2 threads cost 3x the CPU of 1). Run with OMP_WAIT_POLICY=passive there, or use 1.
  int num_threads = 2;

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief GICP for two clouds already within decimetres of each other (consecutive sweeps, consecutive keyframes):
///        1.0 / 0.5 m correspondence stages, at most max_source_points source points, one thread (the callers already
///        run in parallel), fitness 0.3.
GicpConfig near_clouds_gicp(int max_source_points);

/// @brief Outcome of align_gicp.
struct GicpResult {
  bool converged = false;  ///< final stage met the step criterion within max_iterations and fitness >= min_fitness
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  ///< maps source points into the target frame
  double residual = -1;  ///< [m] mean distance of corresponding points within the last schedule distance (-1: none)
  double fitness = 0;    ///< inlier fraction: share of source points with a correspondence within that distance
  int iterations = 0;    ///< Gauss-Newton iterations over all stages
  /// Gauss-Newton Hessian sum J^T M J at the final transform (Ren 2019, Eq. 6), usable as loop-edge information.
  /// Order (rx, ry, rz, tx, ty, tz), right perturbation T * Exp(delta), i.e. in the source frame: the solver's own
  /// parameter order. As information it is used in loopd's order (base/information.hpp, information_from_rotation_first).
  /// Units: the Mahalanobis weights use the normalised covariances diag(eps, 1, 1) [m^2], so H is information up to
  /// a scale (divide by a point noise variance to make it metric).
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  double cost = 0;         ///< final Mahalanobis cost sum (Ren 2019, Eq. 6)
  int num_inliers = 0;     ///< correspondences within the last schedule distance
  double degeneracy = -1;  ///< gicp_degeneracy(H): >= 1, large = ill-conditioned translation (corridor); -1 when unknown
  Eigen::Vector3d weakest_direction = Eigen::Vector3d::Zero();  ///< translation direction (source frame) with least information
  double ms = 0;                                                ///< [ms] wall time including covariance estimation
  double ms_covariances = 0;                                    ///< [ms] of which: k-d trees and per-point covariances
  std::string reason;                                           ///< why converged is false (empty otherwise)
};

/// @brief Generalized ICP: per-point covariances from k neighbours with eigenvalues replaced by (eps, 1, 1)
/// (Ren 2019, Eq. 3), plane-to-plane Mahalanobis cost (Eq. 6), Gauss-Newton on SE(3), one stage per entry of the
/// correspondence distance schedule. Non-finite input points are ignored.
/// @note Deterministic: per-point terms are summed in fixed blocks, then the blocks in order, so the result is the same
/// for any num_threads.
GicpResult align_gicp(const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& target,
                      const Eigen::Isometry3d& init_T_target_source, const GicpConfig& config);

/// @brief The same with precomputed per-point normals (from estimate_gicp_normals, e.g. cached per keyframe), so
/// that a keyframe's covariances are estimated once instead of once per loop candidate. With the eigenvalues fixed to
/// (eps, 1, 1) a GICP covariance is fully determined by its normal n: C = I - (1 - eps) n n^T (Ren 2019, Eq. 3).
/// A zero normal means "no plane" (isotropic covariance). Empty normal vectors: estimated here as in align_gicp.
/// @param source_normals unit normals sized like `source` (or empty)
/// @param target_normals unit normals sized like `target` (or empty)
GicpResult align_gicp(const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& source_normals,
                      const std::vector<Eigen::Vector3f>& target, const std::vector<Eigen::Vector3f>& target_normals,
                      const Eigen::Isometry3d& init_T_target_source, const GicpConfig& config);

/// @brief Per-point surface normals for GICP: smallest-eigenvalue eigenvector of the covariance of the k nearest
/// neighbours (Ren 2019, Eq. 2). Zero vector for non-finite points and where fewer than 4 neighbours exist.
/// @note Deterministic for any num_threads.
std::vector<Eigen::Vector3f> estimate_gicp_normals(const std::vector<Eigen::Vector3f>& points, int k_neighbors, int num_threads);

/// @brief Degeneracy of a GICP Hessian: condition number lambda_max / lambda_min of the translational information after
/// marginalising rotation (Schur complement of the rotation block). ~1-30 for well-constrained street scenes; large
/// (hundreds and more) when translation along one axis is unobservable, e.g. a corridor or tunnel. Returns +inf when
/// the smallest eigenvalue is not positive. `weakest` (optional) receives its eigenvector.
double gicp_degeneracy(const Eigen::Matrix<double, 6, 6>& H, Eigen::Vector3d* weakest = nullptr);

}  // namespace loopd
