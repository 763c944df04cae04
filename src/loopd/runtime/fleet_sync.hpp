#pragma once
/// @file A fleet on one shared map (PostgreSQL): the thread that keeps this vehicle in step with the others. On its
/// own connection it polls the other vehicles' new keyframes (handed to the sequential stage as candidates), takes the
/// solver role when it is free, solves the joint pose graph when loops or keyframes were added and stores it as the
/// next revision, and publishes every revision any solver stored, so every vehicle publishes the same map.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "loopd/correction/loop_corrector.hpp"
#include "loopd/store/map_store.hpp"
#include "loopd/store/shared_map.hpp"
#include "loopd/pipeline/loop_detector.hpp"
#include "loopd/runtime/loopd_engine.hpp"

namespace loopd {

/// @brief Fleet settings (config `fleet.*`, `--vehicle`).
struct FleetConfig {
  int vehicle = -1;                ///< this vehicle's number (0 .. kMaxVehicle); -1: no fleet (a postgresql map makes it 0)
  double poll_interval = 1.0;      ///< [s] how often the other vehicles' keyframes and the joint correction are read
  int solve_every_keyframes = 20;  ///< the solver solves again when this many keyframes were added (or any loop was)
  double flush_timeout = 30.0;     ///< [s] at exit, how long buffered map writes wait for an unavailable server
  std::optional<std::string> validate() const;
};

struct FleetStats {
  std::int64_t remote_keyframes = 0;  ///< other vehicles' keyframes read
  std::int64_t solves = 0;            ///< joint corrections this vehicle solved and stored
  std::int64_t revisions_published = 0;
  std::int64_t newest_revision = 0;
  bool solver = false;  ///< this vehicle holds the solver role now
  std::int64_t errors = 0;
  std::string last_error;
};

class FleetSync {
 public:
  /// @param publish called (from the fleet thread) with each joint correction revision, as a CorrectionOutput whose
  ///        T_map_odom is this vehicle's newest session's alignment.
  FleetSync(const FleetConfig& config, MapStoreConfig map, LoopCorrectorConfig corrector, KeyframeLoad remote_load,
            std::function<void(const CorrectionOutput&)> publish);
  ~FleetSync();
  FleetSync(const FleetSync&) = delete;
  FleetSync& operator=(const FleetSync&) = delete;

  /// @brief Opens the fleet's own connection and starts the thread; the reason when it cannot.
  std::optional<std::string> start();
  /// @brief A last round (read, solve if this vehicle may, publish), then stops the thread.
  void stop();
  /// @brief The other vehicles' keyframes read since the last call (the sequential stage adds them to the detector).
  std::vector<KeyframeRecord> take_remote();
  FleetStats stats() const;

 private:
  void run();
  void round(bool last = false);  ///< `last`: the round at stop, which solves for any keyframe added since the last solve
  void read_remote();
  void solve_if_due(bool last);
  void publish_newest();
  void error(const std::string& what, const StoreStatus& status);

  FleetConfig config_;
  MapStoreConfig map_config_;
  LoopCorrectorConfig corrector_;
  KeyframeLoad remote_load_;
  std::function<void(const CorrectionOutput&)> publish_;
  std::unique_ptr<MapStore> store_;
  SharedMap* shared_ = nullptr;
  std::map<SessionId, std::int64_t> newest_seen_;
  std::optional<FleetCounts> solved_counts_;  ///< what the map held at this vehicle's last solve
  std::int64_t published_revision_ = 0;
  int round_errors_ = 0;  ///< store errors in the current round (the fleet thread's own)

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::vector<KeyframeRecord> inbox_;
  FleetStats stats_;
  std::thread thread_;
};

/// @brief The joint correction as the trajectory publisher takes it; T_map_odom from `vehicle`'s newest session.
CorrectionOutput to_correction_output(const FleetCorrectionRecord& record, int vehicle);

/// @brief In front of the output: passes everything but the detector's own corrections (in a fleet only the joint
/// correction is published; the detector's still go to the map store, for resume, through the writer before it).
class LocalCorrectionFilter : public ForwardingSink {
 public:
  using ForwardingSink::ForwardingSink;
  void on_correction(const CorrectionOutput& /*correction*/) override {}
};

}  // namespace loopd
