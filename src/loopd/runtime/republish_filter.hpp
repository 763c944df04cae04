#pragma once
/// @file After a restart, keeps the loop events published before the stop off the bus when they are decided again.
#include <atomic>
#include <cstdint>
#include <map>
#include <vector>

#include "loopd/runtime/loopd_engine.hpp"

namespace loopd {

/// @brief An EngineSink in front of the publisher. A stop that cuts a keyframe off before it is decided leaves its
/// decisions committed, most of them published (the map writer marks each published after the bus has it), but
/// removes them from the map; after the restart the keyframe is processed again and the detector gives each
/// candidate it decides again the id it had (LoopDetector::expect_decisions). A decision identical to the one
/// published then (same event_id, candidate, status and transform) is stored again but not published again; one that
/// differs, or one that had not reached the bus, is published (a consumer keyed by event_id takes the later one: the
/// message docs say so). Everything else passes unchanged.
class RepublishFilter : public ForwardingSink {
 public:
  using ForwardingSink::ForwardingSink;
  /// @brief The cut-off decisions that had reached the bus (ResumeSummary::cut_off_published), before any input.
  void expect(const std::vector<LoopDecision>& published);
  std::int64_t not_republished() const { return not_republished_.load(); }

  void on_decision(const LoopDecision& decision) override;

 private:
  std::map<std::int64_t, LoopDecision> published_;  ///< by event_id
  std::atomic<std::int64_t> not_republished_{0};    ///< read by status while the engine thread writes
};

}  // namespace loopd
