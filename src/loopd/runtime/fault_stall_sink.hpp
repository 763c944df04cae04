#pragma once
/// @file TEST-ONLY fault injection: stalls loopd's sequential stage once, so the watchdog test can see the pings stop.
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <thread>

#include "loopd/runtime/loopd_engine.hpp"

namespace loopd {

/// @brief TEST-ONLY. An EngineSink in front of another that sleeps `stall_ms` inside the sequential stage when keyframe
/// `at_keyframe` enters the map (once), as a hung verification or a hung map write would; everything is passed on
/// unchanged. Armed only by the environment (LOOPD_FAULT_STALL_AT_KEYFRAME=N and LOOPD_FAULT_STALL_MS=ms, see
/// from_environment()); no config field arms it, and production runs never set these variables.
class FaultStallSink : public ForwardingSink {
 public:
  FaultStallSink(EngineSink& next, std::int64_t at_keyframe, int stall_ms) : ForwardingSink(next), at_keyframe_(at_keyframe), stall_ms_(stall_ms) {}

  /// @brief The stall the environment asks for: {keyframe index, milliseconds}, nothing when either is unset or < 0 / <= 0.
  static std::optional<std::pair<std::int64_t, int>> from_environment() {
    const char* at = std::getenv("LOOPD_FAULT_STALL_AT_KEYFRAME");
    const char* ms = std::getenv("LOOPD_FAULT_STALL_MS");
    if (!at || !ms || std::atoll(at) < 0 || std::atoi(ms) <= 0) return std::nullopt;
    return std::make_pair(static_cast<std::int64_t>(std::atoll(at)), std::atoi(ms));
  }

  void on_keyframe(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_sensor, const MapCloudBlob& map_cloud) override {
    if (!stalled_ && keyframe.key.index >= at_keyframe_) {
      stalled_ = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(stall_ms_));
    }
    next_.on_keyframe(keyframe, T_map_sensor, map_cloud);
  }

 private:
  std::int64_t at_keyframe_;
  int stall_ms_;
  bool stalled_ = false;  ///< sequential stage only: one thread at a time
};

}  // namespace loopd
