#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/pose.hpp"
#include "loopd/eval/loop_ground_truth.hpp"
#include "loopd/eval/pose_error.hpp"
#include "loopd/eval/session_metrics.hpp"
#include "loopd/records/loop_decision.hpp"

namespace loopd {

/// @brief One corrected keyframe pose (the last trajectory_t revision).
struct KeyframePose {
  std::int64_t utime = 0;  ///< [us]
  Eigen::Isometry3d T_map_sensor = Eigen::Isometry3d::Identity();
  std::int32_t session = 0;  ///< loopd session of the keyframe (trajectory_t.keyframe_sessions)
};

/// @brief Everything the evaluation needs, read from a drive log and loopd's output log.
struct EvalInput {
  std::vector<StampedPose> ground_truth;                         ///< T_world_sensor, sorted by utime
  std::vector<StampedPose> odometry;                             ///< T_odom_sensor, sorted by utime
  std::vector<std::int64_t> scan_utimes;                         ///< [us] in drive order: the index is the frame number
  std::vector<LoopDecision> loops;                               ///< every loop event
  std::vector<KeyframePose> corrected;                           ///< last trajectory revision, oldest first (may be empty)
  Eigen::Isometry3d T_map_odom = Eigen::Isometry3d::Identity();  ///< of that revision (for later keyframes)
  std::vector<SessionAnchor> sessions;                           ///< that revision's session list (empty in older logs)
};

struct EvalConfig {
  LoopGroundTruthConfig ground_truth;               ///< loop ground truth (Vlaminck 2019, 5.3)
  double closure_max_translation = 0.5;             ///< [m] accepted loop correct when T_match_query is within this ...
  double closure_max_rotation_deg = 2.0;            ///< [deg] ... and this of ground truth
  std::int64_t max_interpolation_gap_us = 1000000;  ///< [us] interpolate ground truth / odometry across gaps up to this
  std::int64_t max_nearest_gap_us = 100000;         ///< [us] else use the nearest pose when this close
  SessionMetricsConfig sessions;                    ///< multi-session figures (mapped area radius)
  std::optional<std::string> validate() const;
};

/// @brief The verdict on one deduplicated loop pair.
struct LoopCheck {
  std::size_t loop = 0;                                    ///< index into EvalInput::loops (the decisive event of this pair)
  bool has_ground_truth = false;                           ///< both ends had a ground-truth pose
  bool true_loop = false;                                  ///< ground truth: same place (distance, frame gap)
  bool correct = false;                                    ///< accepted and T_match_query within tolerance of ground truth
  double gt_distance = -1;                                 ///< [m] ground-truth distance of the two places (3D or planar per config)
  std::int64_t frame_gap = 0;                              ///< scans between query and match
  double translation_error = -1, rotation_error_deg = -1;  ///< of T_match_query against ground truth
  int query_keyframe = -1, match_keyframe = -1;            ///< indices into EvalReport::keyframe_utimes
};

/// @brief A point of the precision-recall curve over the descriptor threshold.
struct PrPoint {
  double threshold = 0;  ///< descriptor distance: pairs with distance <= threshold are detections
  double precision = 0, recall = 0;
  int true_positives = 0, false_positives = 0;
};

/// @brief Loop detection under Vlaminck 2019, 5.3. Headline numbers count ACCEPTED loops; the PR curve counts
///        every pair with a descriptor distance (the descriptor's own quality, before geometric verification).
///        precision = TP / (TP + FP) over loop pairs; recall = ground-truth query keyframes with at least one true
///        accepted loop / all ground-truth query keyframes; FN = ground-truth query keyframes with none.
struct DetectionMetrics {
  int true_positives = 0, false_positives = 0, false_negatives = 0;
  double precision = 0, recall = 0, f1 = 0;
  int gt_queries = 0;         ///< keyframes with a ground-truth partner
  std::int64_t gt_pairs = 0;  ///< ground-truth pairs among keyframes
  std::vector<PrPoint> pr_curve;
  double max_recall = 0, precision_at_max_recall = 0, f1_max = 0, f1_max_threshold = 0;
};

/// @brief Loop closure correctness of accepted loops.
struct ClosureMetrics {
  int accepted = 0, correct = 0;
  double precision = 0;       ///< correct / accepted
  double recall = 0;          ///< gt query keyframes with an accepted loop / all gt query keyframes
  double recall_correct = 0;  ///< same, counting only correct accepted loops
  int stretches = 0;          ///< revisited stretches (maximal runs of consecutive revisit keyframes)
  int stretches_closed = 0;   ///< stretches with at least one correct accepted loop whose query lies in them
  double stretches_closed_share = 0;
  /// Each stretch: its first and last keyframe (index into the evaluated keyframes) and whether it was closed.
  struct Stretch {
    int first = 0, last = 0;
    bool closed = false;
  };
  std::vector<Stretch> stretch_list;
};

/// @brief Median / p95 / max of one per-stage timing [ms] over the events where the stage ran (value > 0).
struct TimingStats {
  double median = 0, p95 = 0, max = 0;
  std::size_t count = 0;
};

struct EvalReport {
  bool ok = false;
  std::string error;
  std::vector<std::string> warnings;

  // Keyframes evaluated (trajectory keyframes, loop ends, and the tail after the last revision).
  std::vector<std::int64_t> keyframe_utimes;
  std::vector<std::int64_t> keyframe_frames;        ///< scan index of each keyframe
  std::vector<Eigen::Isometry3d> gt_keyframes;      ///< ground truth at the keyframes
  std::vector<Eigen::Isometry3d> before_keyframes;  ///< odometry, aligned to ground truth at the first keyframe
  std::vector<Eigen::Isometry3d> after_keyframes;   ///< corrected, aligned to ground truth at the first keyframe
  std::vector<Eigen::Vector3d> gt_path;             ///< every ground-truth position (for plots and closest-pose error)
  LoopGroundTruth loop_ground_truth;                ///< over the keyframes
  std::vector<LoopCheck> checks;                    ///< one per deduplicated loop pair

  DetectionMetrics detection;
  ClosureMetrics closure;
  ErrorStats error_before, error_after;  ///< closest-pose error (Vlaminck 2019, Table 4) [m]
  ErrorStats loop_translation_error;     ///< [m] T_match_query of the accepted loops (with ground truth) against ground truth
  ErrorStats loop_rotation_error_deg;    ///< [deg] the same, rotation
  double ate_before = 0, ate_after = 0;  ///< ATE RMSE after SE(3) Umeyama alignment [m]
  bool has_corrected = false;
  SessionMetrics sessions;  ///< multi-session figures over the corrected trajectory's keyframes
  TimingStats ms_descriptor, ms_fourpcs, ms_gicp, ms_hungarian, ms_total;
};

/// @brief Runs the whole evaluation. Keyframes without ground truth are dropped with a warning.
EvalReport evaluate(const EvalInput& input, const EvalConfig& config);

/// @brief Precision-recall curve from (descriptor distance, is-true, ground-truth query keyframe or -1) triples.
///        Recall counts distinct query keyframes reached by true detections, over `gt_queries`.
std::vector<PrPoint> precision_recall_curve(const std::vector<double>& distances, const std::vector<bool>& is_true,
                                            const std::vector<int>& query_keyframes, int gt_queries);

}  // namespace loopd
