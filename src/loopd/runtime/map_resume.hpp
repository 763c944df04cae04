#pragma once
/// @file Restarting on a map: the detector is brought back to where the map store says it stopped.
#include <cstdint>
#include <string>
#include <vector>

#include "loopd/runtime/session_keys.hpp"
#include "loopd/store/map_store.hpp"
#include "loopd/pipeline/loop_detector.hpp"

namespace loopd {

/// @brief What resume_detector() restored.
struct ResumeSummary {
  bool ok = false;
  std::string error;                   ///< why the map could not be resumed (the map is then left as it was)
  std::int64_t keyframes = 0;          ///< keyframes restored
  std::int64_t decisions = 0;          ///< decisions restored
  std::int64_t dropped_undecided = 0;  ///< keyframes whose decisions were cut off by the stop (made again)
  std::int64_t revision = 0;           ///< correction revision restored (0: none stored)
  std::vector<StoredKeyframe> stored;  ///< every restored keyframe, in map order (SessionKeys recognises them in a replay)
  /// Decisions removed with the keyframes the stop cut off: the detector gives the same candidates the same ids
  /// again; of those that had reached the bus (cut_off_published), RepublishFilter keeps identical ones off it.
  std::vector<LoopDecision> cut_off, cut_off_published;
  /// Corrections made again: accepted loops whose correction the stop cut off. The caller stores and publishes them.
  std::vector<CorrectionOutput> corrections;
  std::int64_t loops_revoked = 0;       ///< accepted loops the map's loop ledger revokes (out of the graph)
  std::int64_t keyframes_retired = 0;   ///< keyframes the map holds retired (poses only: never candidates)
  std::vector<LoopLedgerEntry> ledger;  ///< the ledger as read (a LedgerWatch goes on from its newest entry)
  /// The ledger changed since the stored correction: the graph was solved again without the loops it now revokes (the
  /// last of `corrections`, method "ledger").
  bool ledger_corrected = false;
  double seconds = 0.0;
};

/// @brief Replays the map into `detector` (fresh, same configuration as when the map was made): each keyframe, then
/// the decisions its query made; the stored correction where it was made; corrections the stop cut off made again.
/// Keyframes whose decisions were not all stored are removed from the map first (they are processed again).
/// @param load kFull: every keyframe's prepared scan comes back into memory; kDescriptor: only descriptors (the detector
///        keeps its features in the store and reads candidates back, LoopDetector::keep_features_in_store).
/// @param read_only nothing is written (a map opened read-only to localize in): keyframes a stop cut off stay, restored
///        with the decisions they have.
ResumeSummary resume_detector(MapStore& store, LoopDetector& detector, KeyframeLoad load = KeyframeLoad::kFull, bool read_only = false);

}  // namespace loopd
