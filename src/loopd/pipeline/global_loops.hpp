#pragma once
/// @file Loops without a pose prior: candidates from place retrieval over every stored keyframe (not only those the
/// distance gate lets through), and the stricter test they pass before they link two frames.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>

#include "loopd/descriptor/scan_context.hpp"
#include "loopd/records/keyframe_key.hpp"
#include "loopd/retrieval/place_index.hpp"

namespace loopd {

/// @brief Global retrieval: a second place descriptor (Scan Context, Kim & Kim 2018) searched over all keyframes.
struct GlobalRetrievalConfig {
  bool enabled = true;           ///< false: candidates from the distance gate only (Vlaminck 2019's pipeline)
  ScanContextConfig descriptor;  ///< the place descriptor every keyframe gets
  RetrievalConfig retrieval;     ///< k-NN over ring keys, then the shift-minimised distance
  int max_verified = 1;          ///< prior-free candidates verified per keyframe, best first
  /// [m] the query's place descriptor is also computed from points lateral_shift to either side of the sensor (0: off):
  /// a polar grid is not translation invariant, and a revisit in the other lane or the other direction is seen from a
  /// few metres aside (Scan Context++'s lateral augmentation, Kim et al., T-RO 2021). The nearest of the three wins.
  double lateral_shift = 3.5;
  /// A place in the query's own frame (its session, or one tied to it) farther from the query's corrected position than
  /// this share of the distance travelled since the last loop is not verified: odometry drifting more is not odometry
  /// (1.5x the 10 % the gate assumes; the ring route with 3 deg / 100 m heading and 3 % scale bias drifts 11 % by its
  /// first revisit, and on seed 2 a look-alike street 24 % away passed verification on 5 consecutive keyframes).
  double max_drift_fraction = 0.15;
  /// [m] a candidate of the query's own session must lie this far back along the drive (nearer ones are the gate's)
  double min_travel_gap = 100.0;
  /// A verified prior-free loop links nothing until a loop of one of the next confirm_window keyframes of its session
  /// implies the same correction of the query's placement (within confirm_translation at the query and
  /// confirm_rotation_deg): a wrong link between two sessions would bend both maps.
  int confirm_window = 3;
  double confirm_translation = 0.5;   ///< [m]
  double confirm_rotation_deg = 2.0;  ///< [deg]
  std::optional<std::string> validate() const;
};

/// @brief A verified prior-free loop and the correction it implies for its query's session: the rigid motion that
/// moves the query's current map pose onto the pose the loop measures, C = T_map_match * T_match_query * T_map_query^-1.
struct PriorFreeLoop {
  KeyframeKey query;
  SessionId match_group = 0;  ///< group (SessionFrames) of the match's session
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  Eigen::Vector3d p_map_query = Eigen::Vector3d::Zero();  ///< the query's position before the correction
  std::int64_t event_id = 0;
};

/// @brief Holds the newest unconfirmed prior-free loop and says when another one confirms it.
class PriorFreeConfirmation {
 public:
  explicit PriorFreeConfirmation(const GlobalRetrievalConfig& config) : config_(config) {}
  /// @brief The held loop that `loop` agrees with (it is then let go), or nothing: `loop` is held instead.
  std::optional<PriorFreeLoop> confirm(const PriorFreeLoop& loop);
  /// @brief Forget the held loop (a gated loop placed its session meanwhile, or a restart).
  void clear() { held_.reset(); }
  /// @brief Translation [m] and rotation [deg] by which two corrections disagree, measured at `loop`'s query.
  static std::pair<double, double> disagreement(const PriorFreeLoop& a, const PriorFreeLoop& b);

 private:
  GlobalRetrievalConfig config_;
  std::optional<PriorFreeLoop> held_;
};

}  // namespace loopd
