#pragma once
#include <cstdint>
#include <string>
#include <map>
#include <utility>
#include <vector>

#include <loopd/trajectory_t.hpp>

#include "bounded_decode.hpp"

namespace loopd {

/// @brief Rebuilds the corrected trajectory from trajectory_t messages in publication order: a full message
///        (full = true) replaces it, a partial one updates the keyframes it names (by session and id) and appends the new ones.
///        A message of an older revision than the one held is ignored (revisions increase with every correction).
class TrajectoryAssembly {
 public:
  /// @brief Applies one message; false when it was ignored (older revision).
  bool apply(const trajectory_t& msg);
  /// @brief The trajectory of the newest revision applied, every keyframe known (full = true), oldest first.
  trajectory_t current() const;
  /// @brief A message was applied.
  bool has_revision() const { return applied_ > 0; }
  std::int64_t revision() const { return header_.revision; }
  /// @brief Keyframes held and the count the newest message announced differ (a message was lost, or no full
  ///        snapshot came before the partial ones): the poses held are still the newest known, but not all of them.
  bool complete() const { return has_snapshot_ && static_cast<std::int64_t>(keyframes_.size()) == header_.total_keyframes; }
  std::int64_t messages() const { return applied_; }
  std::int64_t snapshots() const { return snapshots_; }

 private:
  trajectory_t header_;  ///< the newest message applied, without its keyframes
  std::vector<keyframe_pose_t> keyframes_;
  std::vector<std::int32_t> sessions_;                                         ///< session of keyframes_[i]
  std::map<std::pair<std::int32_t, std::int64_t>, std::size_t> index_of_key_;  ///< (session, id) -> position
  bool has_snapshot_ = false;
  std::int64_t applied_ = 0, snapshots_ = 0;
};

/// @brief Decodes a trajectory_t of either version (see decode_trajectory_v1) with decode_bounded's checks; `why`
///        gets today's decoder's reason when neither decodes.
bool decode_any_trajectory(const void* data, std::size_t size, trajectory_t* out, std::string* why = nullptr);

}  // namespace loopd
