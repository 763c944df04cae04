#pragma once
// Pose-graph optimisation of keyframe poses (Ren 2019, Sec. 3.4) solved with Ceres; no Ceres types in this header.
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "loopd/correction/loop_correction.hpp"

namespace loopd {

/// @brief Robust kernel applied to loop edges.
enum class RobustLoss { kNone, kHuber, kCauchy };

/// @brief Ground / roadway plane seen from one keyframe (Ren 2019, Sec. 3.4.2), in that keyframe's sensor frame:
/// n . x + d = 0 for points x on the plane, |n| = 1. All observations with the same plane_id constrain one plane
/// node (a unit normal + offset in the world frame, optimised together with the poses).
struct PlaneObservation {
  PoseIndex index = -1;                                        ///< position of the keyframe in the pose sequence
  int plane_id = 0;                                            ///< plane node this observation belongs to
  Eigen::Vector4d plane_sensor = Eigen::Vector4d(0, 0, 1, 0);  ///< (n, d) in the sensor frame
};

/// @brief Settings of the pose graph.
struct PoseGraphConfig {
  /// Odometry edge sigma for an edge of average weight [m] / [rad]; an edge's variance scales with its weight
  /// c_ij / mean(c) from edge_weights() (residual-based, the same shares the heuristic uses).
  double odometry_translation_sigma = 0.05;
  double odometry_rotation_sigma = 0.002;
  HeuristicCorrectionConfig weights;  ///< how c_ij is computed (residuals, distance weighting)

  /// Loop edges: sigma used when LoopConstraint::information is all zero [m] / [rad].
  double loop_translation_sigma = 0.05;
  double loop_rotation_sigma = 0.005;
  /// A given loop information (e.g. a GICP Hessian summed over thousands of points) is scaled down so its largest
  /// eigenvalue is at most this (i.e. no direction more certain than ~2 cm / ~0.02 rad), and floored at
  /// min_loop_information so degenerate directions stay weak but bounded.
  double max_loop_information = 2500.0;
  double min_loop_information = 1e-2;

  RobustLoss loop_loss = RobustLoss::kCauchy;  ///< robust kernel on loop edges so one bad loop cannot bend the map
  /// Kernel scale in units of the whitened residual (sigmas). Measured on synthetic laps (loopd-bench-like drive, 5 m
  /// wrong loop 10..100 keyframes beside a true one): 1 rejects a lone true loop whose drift is large against the
  /// odometry sigmas (8/8 seeds); 2 and 2.5 let the wrong loop bend the map ~2.7 m at some offsets; 1.5 does neither.
  double loop_loss_scale = 1.5;

  /// Graduated robust kernel: when the initial loop residuals are large (e.g. starting from raw odometry), first
  /// solve with the kernel scale multiplied by graduated_start_factor, then shrink it by 10x per stage.
  bool graduated = true;
  double graduated_start_factor = 1000.0;

  /// Ground/roadway plane constraints (Ren 2019, Sec. 3.4.2): each PlaneObservation adds a residual between the
  /// plane node seen from the pose and the observed plane (normal direction difference and offset difference).
  bool use_plane_constraints = false;
  double plane_normal_sigma = 0.01;    ///< [rad]
  double plane_distance_sigma = 0.05;  ///< [m]

  /// Solve only the keyframes that carry more than odometry (first pose, loop ends, plane observations) with the
  /// odometry chains between them composed into one edge each (covariance propagated); the chains are then filled in
  /// with the heuristic's shares. Exact for the chain's least-squares problem to first order, and 10-100x faster.
  /// Off: the full graph with one edge per keyframe step.
  bool reduce_chains = true;
  /// With reduce_chains, also keep every chain_stride-th keyframe as a node (0: loop ends only), so long chains
  /// bend like the full graph; ~n/chain_stride nodes.
  int chain_stride = 30;
  /// With reduce_chains, when loop ends are dense (half the keyframes or more: consecutive keyframes of a revisit
  /// all close loops), the nodes are every loop_end_stride-th keyframe instead and each loop end moves to the
  /// nearest node through its (at most loop_end_stride / 2 steps of) odometry, so the graph stays ~n/loop_end_stride
  /// nodes on long drives. 1: the full graph in that case.
  int loop_end_stride = 2;
  /// With reduce_chains, at most this many nodes (0: no bound): when the layout above would have more, the nodes are
  /// every k-th keyframe, k = ceil(n / (max_nodes - 1)), loop ends moved to their nearest node as for dense loop ends,
  /// and one loop edge per node pair. Bounds a solve's memory and time on a drive of any length: the factor of a
  /// 1.3 km lap visited 45 times (20,500 keyframes, 20,119 loops) took 110 MB with 4000 nodes (its size grows with the
  /// nodes times the passes linked at a place). Loop ends then move through at most k / 2 odometry steps. On that
  /// drive (map.cache_mb 64) loopd's peak RSS was 350 MB with 2500 nodes and 318 MB with 1500, ATE 0.698 vs 0.694 m.
  int max_nodes = 1500;

  int max_iterations = 50;
  double function_tolerance = 1e-8;
  int num_threads = 1;

  std::optional<std::string> validate() const;
};

/// @brief Result of the pose graph.
struct PoseGraphResult {
  std::vector<Eigen::Isometry3d> poses;  ///< corrected keyframe poses (pose 0 is held fixed)
  bool converged = false;
  int iterations = 0;
  double initial_cost = 0, final_cost = 0;
  double ms = 0;                        ///< [ms] wall time of build + solve
  std::string message;                  ///< solver summary line or the reason for failure
  std::vector<Eigen::Vector4d> planes;  ///< optimised plane nodes (world frame), by plane_id
};

/// @brief Builds and solves the pose graph: odometry edges between consecutive keyframes (from odometry_poses, weighted
/// by residuals), loop edges (robust kernel), optional plane constraints; starts from initial_guess (e.g. the heuristic;
/// empty -> odometry). odometry_information, when non-empty, gives each edge (i-1, i) its 6x6 information in
/// (t, r) order at index i and replaces the residual-based one. segment_starts: poses whose step (i-1, i) joins two
/// odometry segments (sessions) rather than measuring motion; i-1 and i are always solved as nodes, so no loop end or
/// plane observation is moved across the join (its weak information is given in odometry_information).
PoseGraphResult optimize_pose_graph(const std::vector<Eigen::Isometry3d>& odometry_poses, const std::vector<double>& residuals,
                                    const std::vector<LoopConstraint>& loops, const std::vector<Eigen::Isometry3d>& initial_guess,
                                    const PoseGraphConfig& config, const std::vector<PlaneObservation>& planes = {},
                                    const std::vector<Eigen::Matrix<double, 6, 6>>& odometry_information = {},
                                    const std::vector<PoseIndex>& segment_starts = {});

}  // namespace loopd
