#pragma once
// One-pass heuristic loop correction (Vlaminck et al. 2019, Sec. 4.4).
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "loopd/base/information.hpp"

namespace loopd {

/// @brief Position of a keyframe in the pose sequence handed to the correction (not a keyframe's name: the caller maps
/// its KeyframeKeys to positions).
using PoseIndex = std::int64_t;
/// @brief [start, end] positions of a loop already closed.
using ClosedSpan = std::pair<PoseIndex, PoseIndex>;

/// @brief A verified loop: keyframe `query_index` (usually the newer one) seen again at keyframe `match_index`.
/// T_match_query maps query-sensor coordinates into match-sensor coordinates, i.e. the corrected poses must satisfy
/// T_world_query = T_world_match * T_match_query.
struct LoopConstraint {
  PoseIndex query_index = -1;  ///< position of the query keyframe in the pose sequence being corrected
  PoseIndex match_index = -1;  ///< position of the match keyframe in that sequence
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  /// Information of T_match_query, e.g. the GICP Hessian (Ren 2019, Sec. 3.4.1), in loopd's one order
  /// (base/information.hpp). All zero = unknown (the pose graph then uses PoseGraphConfig::loop_translation_sigma /
  /// loop_rotation_sigma).
  Information6d information = Information6d::Zero();
  /// false: the pose graph takes this loop without its robust kernel (a loop already proven an inlier, e.g. confirmed
  /// by the loops of the next keyframes); true: robust (PoseGraphConfig::loop_loss).
  bool robust = true;
};

/// @brief Settings of the heuristic correction (Vlaminck 2019, Sec. 4.4).
struct HeuristicCorrectionConfig {
  /// Edge weight c_ij = max(residual_j, min_weight_fraction * mean positive residual): a high scan-matching
  /// residual takes a larger share of the loop error; keeps zero-residual edges from getting no share at all.
  double min_weight_fraction = 0.1;
  /// Also multiply c_ij by the step length [m] (+ min_step_length), so drift that grows with distance travelled is
  /// spread by distance and standstill frames take no share; off = the paper's d(V_k, V_l) = sum c_ij over edges
  /// only. On by default: measured better on KITTI 00/05 with injected drift (10 Hz frames include standstills).
  bool distance_weighting = true;
  double min_step_length = 0.05;  ///< [m] floor of the step length when distance_weighting is on
  /// Weight factor for edges inside the span of a loop that was already closed (correct_heuristic_all / LoopCorrector):
  /// 0 keeps earlier (nested) loops exactly closed by moving their stretch rigidly. Falls back to 1 when every
  /// edge of the new loop lies in closed spans.
  double closed_span_weight = 0.0;
  /// true: pose i is moved by the fraction w_i of the world-frame loop error D as a rigid motion whose rotation is
  /// about the position of V_s (so positions swing with the slerped rotation, which undoes heading drift along the
  /// loop); false: the literal reading of Sec. 4.4 -- position + w_i * (translation error at V_e), orientation
  /// slerped, positions not rotated. Both close the loop exactly.
  bool rotate_positions = true;

  std::optional<std::string> validate() const;
};

/// @brief Edge weights c_i for the edge (i-1, i), i = 1..n-1 (entry 0 is 0). residuals[i] is the scan-matching
/// residual of the step ending at pose i (as in StampedPose::residual); any size other than poses.size(), or all zero,
/// means unknown and gives equal weights.
std::vector<double> edge_weights(const std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& residuals,
                                 const HeuristicCorrectionConfig& config);

/// @brief Outcome of one heuristic correction (for diagnostics).
struct HeuristicCorrectionResult {
  bool applied = false;               ///< false for a zero-length loop or indices out of range (poses unchanged)
  std::string reason;                 ///< why not applied
  PoseIndex start_index = -1;         ///< s = min(query, match)
  PoseIndex end_index = -1;           ///< e = max(query, match)
  double correction_translation = 0;  ///< [m] translation of the loop error at V_e
  double correction_rotation = 0;     ///< [rad] rotation of the loop error
};

/// @brief Applies one loop in place with given edge weights (size poses.size(), see edge_weights).
/// The loop error D = V_s T_se V_e^-1 (Vlaminck's Delta with the measured loop transform T_se removed, written as a
/// world-frame correction) is spread over s..e: pose i gets the fraction w_i = d(V_s,V_i)/d(V_s,V_e) (Eq. 3),
/// rotation by slerp about the position of V_s and translation linearly; poses after V_e get all of D (rigid).
/// After the call V_s^-1 V_e == T_se exactly (to rounding). O(n).
HeuristicCorrectionResult apply_heuristic_correction(std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& weights,
                                                     const LoopConstraint& loop, bool rotate_positions = true);

/// @brief The heuristic for one loop (contract entry point). Returns every pose, corrected.
std::vector<Eigen::Isometry3d> correct_heuristic(const std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& residuals,
                                                 const LoopConstraint& loop, const HeuristicCorrectionConfig& config);

/// @brief All loops, one after the other in order of their end index (so nested loops are closed inside-out);
/// edges inside already closed spans get closed_span_weight, so earlier loops stay closed.
std::vector<Eigen::Isometry3d> correct_heuristic_all(const std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& residuals,
                                                     const std::vector<LoopConstraint>& loops, const HeuristicCorrectionConfig& config);

/// @brief Incremental form used by LoopCorrector: applies `loop` to `poses` (already corrected for the loops whose
/// spans are in `closed_spans`), then appends its span. base_weights from edge_weights().
HeuristicCorrectionResult apply_heuristic_with_spans(std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& base_weights,
                                                     const LoopConstraint& loop, std::vector<ClosedSpan>& closed_spans,
                                                     const HeuristicCorrectionConfig& config);

}  // namespace loopd
