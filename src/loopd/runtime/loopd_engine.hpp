#pragma once
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "loopd/base/deskew.hpp"
#include "loopd/base/imu.hpp"
#include "loopd/registration/sweep_motion.hpp"
#include "loopd/store/map_cloud.hpp"
#include "loopd/pipeline/keyframe_selector.hpp"
#include "loopd/pipeline/keyframe_submap.hpp"
#include "loopd/pipeline/loop_detector.hpp"
#include "loopd/runtime/map_resume.hpp"
#include "loopd/runtime/clock_watch.hpp"
#include "loopd/runtime/ledger_watch.hpp"
#include "loopd/runtime/odometry_reset_filter.hpp"
#include "loopd/runtime/scan_loss_estimator.hpp"
#include "loopd/runtime/scan_pose_associator.hpp"
#include "loopd/runtime/session_keys.hpp"
#include "loopd/runtime/sensor_layout_watch.hpp"
#include "loopd/runtime/progress_watch.hpp"

namespace loopd {

/// @brief Engine settings beyond the detector's: association, threads, queues, input limits.
struct EngineConfig {
  AssociationConfig association;
  DeskewConfig deskew;  ///< motion compensation of keyframe scans that carry per-point times, before their features
  /// Deskew with the sweep's motion measured by the keyframe's scan and the scan before it (estimate_sweep_motion)
  /// where the odometry has no pose inside the sweep (10 Hz odometry: its increments' step noise would bend the scan);
  /// the odometry's motion where the scans disagree with it or do not register (deskew.from_scans).
  bool deskew_from_scans = true;
  /// The scans arrive motion-compensated (deskewed by their driver or by the odometry, e.g. a LIO's undistorted cloud):
  /// scans without per-point times count as free of skew, so their keyframe steps are measured (correction.steps).
  bool compensated_upstream = false;
  SweepMotionConfig sweep_motion;
  /// Gyro samples (push_imu) bend each sweep's path as the sensor turned through it, and give the previous sweep's
  /// rotation, where deskew_from_scans measures the sweep's motion (imu.*).
  struct Imu {
    bool enabled = true;
    std::vector<double> rpy_deg{0.0, 0.0, 0.0};  ///< [deg] roll, pitch, yaw of the IMU in the lidar's frame (R_sensor_imu)
    double max_gap = 0.05;                       ///< [s] samples farther apart leave the sweep to the odometry's poses
  } imu;
  KeyframeSubmapConfig submap;  ///< a narrow or sparse scan's keyframe cloud from the scans just before it
  LoopDetectorConfig detector;
  int num_threads = 0;                         ///< feature/verification workers; 0 = hardware threads
  int queue_capacity = 16;                     ///< keyframes waiting for a worker (see ready_capacity() for the sequential stage)
  bool block_when_full = false;                ///< replay: wait for workers; live: shed (see docs/reliability.md)
  std::int64_t max_points_per_scan = 2000000;  ///< larger scans are rejected as invalid
  double clock_jump = 2.0;                     ///< [s] data clock vs arrival clock disagreement that is a clock jump (input.clock_jump)
  double max_odometry_speed = 60.0;            ///< [m/s] faster apparent odometry motion is an odometry reset (input.max_odometry_speed)
  SessionPolicy sessions;                      ///< when a drive or an odometry reset opens a new session (sessions.*)
  MapCloudConfig map_cloud;                    ///< the keyframes' map clouds (map.cloud_*), made when a map store is open
  /// Area-bounded maps (retirement.*): after a keyframe closes a loop, the keyframes its place holds beyond the policy's
  /// bound are retired (never candidates again; the map store frees their features and map clouds).
  PlaceDensityConfig retirement;
  std::optional<std::string> validate() const;
};

/// @brief An encoded keyframe map cloud (store/map_cloud_codec.hpp), shared read-only.
using MapCloudBlob = std::shared_ptr<const std::vector<std::uint8_t>>;

/// @brief Receives the engine's results (called from a worker thread, one call at a time).
class EngineSink {
 public:
  virtual ~EngineSink() = default;
  /// @brief A keyframe entered the map (before any of its decisions).
  /// `map_cloud`: its encoded map cloud (encode_map_cloud), null unless make_map_clouds() was called.
  virtual void on_keyframe(const KeyframeRecord& /*keyframe*/, const Eigen::Isometry3d& /*T_map_sensor*/, const MapCloudBlob& /*map_cloud*/) {}
  virtual void on_decision(const LoopDecision& decision) = 0;
  virtual void on_correction(const CorrectionOutput& correction) = 0;
  /// @brief The end of a run (finish()): every keyframe and loop solved once more in one pose graph
  ///        (LoopDetector::final_correction), the trajectory to take away. A map store keeps it as its correction (a
  ///        restart resumes from it at the newest keyframe).
  virtual void on_final_correction(const CorrectionOutput& /*correction*/) {}
  /// @brief Every decision of `keyframe` (and its correction, if any) has been delivered.
  virtual void on_keyframe_decided(const KeyframeKey& /*keyframe*/) {}
  /// @brief Keyframes the place density policy retired after `by` closed a loop (all decided before it): never
  /// candidates again; their poses stay in every trajectory. A map store frees their features and map clouds.
  virtual void on_keyframes_retired(const KeyframeKey& /*by*/, const std::vector<KeyframeKey>& /*retired*/) {}
  /// @brief The sequential stage is idle (LoopdEngine::tick, live): a moment for background work such as retrying
  /// buffered map writes. Never concurrent with the calls above.
  virtual void on_idle() {}
};

/// @brief A sink in front of another that passes every call on; filters derive from it and override what they change.
class ForwardingSink : public EngineSink {
 public:
  explicit ForwardingSink(EngineSink& next) : next_(next) {}
  void on_keyframe(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_sensor, const MapCloudBlob& map_cloud) override {
    next_.on_keyframe(keyframe, T_map_sensor, map_cloud);
  }
  void on_decision(const LoopDecision& decision) override { next_.on_decision(decision); }
  void on_correction(const CorrectionOutput& correction) override { next_.on_correction(correction); }
  void on_final_correction(const CorrectionOutput& correction) override { next_.on_final_correction(correction); }
  void on_keyframe_decided(const KeyframeKey& keyframe) override { next_.on_keyframe_decided(keyframe); }
  void on_keyframes_retired(const KeyframeKey& by, const std::vector<KeyframeKey>& retired) override { next_.on_keyframes_retired(by, retired); }
  void on_idle() override { next_.on_idle(); }

 protected:
  EngineSink& next_;
};

/// @brief Counters reported in status_t.
/// @brief Where the engine's time went, summed over the run [ms] (loopd-bench pipeline --profile). Thread CPU time
/// spent in each stage, not waits: the ingest thread's time excludes waiting for room in the worker queue.
struct EngineProfile {
  double ingest_ms = 0;                 ///< push_scan without the wait: checks, association, keyframe rule, reference scans (per scan)
  double sweep_motion_ms = 0;           ///< worker: a keyframe sweep's motion measured by the scans (deskew.from_scans)
  double deskew_ms = 0;                 ///< worker: deskew of the keyframe scan (and copying the shared raw scan)
  double descriptor_ms = 0;             ///< worker: M2DP and the Scan Context descriptors
  double prepare_ms = 0;                ///< worker: range image, segmentation, voxel cloud, normals, sensor layout
  double map_cloud_ms = 0;              ///< worker: the keyframe's map cloud, reduced and encoded
  double sequential_ms = 0;             ///< LoopDetector::add_keyframe: the keyframe's step, gate, ranking, verification, correction
  double verify_ms = 0;                 ///< of it: candidates verified (4PCS, GICP, Hungarian)
  double correction_ms = 0;             ///< of it: corrections (heuristic and pose graph)
  std::int64_t keyframes_prepared = 0;  ///< keyframes the workers prepared (not shed)
};

struct EngineStats {
  std::int64_t scans_in = 0, poses_in = 0;
  std::int64_t invalid_scans = 0;            ///< empty, all non-finite, too large, duplicate or out-of-order utime
  std::int64_t invalid_poses = 0;            ///< duplicate or out-of-order utime
  std::int64_t imu_in = 0, invalid_imu = 0;  ///< gyro samples pushed; of them with a duplicate or out-of-order utime
  std::int64_t dropped_no_pose = 0;          ///< scans with no pose within tolerance / hold time
  std::int64_t keyframes = 0;
  std::int64_t shed = 0;              ///< keyframes whose features were skipped because the queue was full
  std::int64_t feature_failures = 0;  ///< keyframes whose descriptor/segmentation failed (too few points...)
  std::int64_t nan_points = 0;
  int queue_depth = 0;
  int pending_scans = 0;
  std::int64_t loops_accepted = 0, loops_rejected = 0;
  std::int64_t steps_measured = 0;  ///< keyframe steps measured by the scans (correction.steps)
  std::int64_t steps_refused = 0;   ///< keyframe steps left to the odometry: the registration was not believed
  std::int64_t steps_skewed = 0;    ///< ... and not measured: the scan may be skewed (no per-point times, moving)
  std::int64_t bytes_per_keyframe = 0;
  std::int64_t cached_feature_bytes = 0;     ///< with the map store keeping features: bytes in the LRU cache
  std::int64_t scans_lost_estimate = 0;      ///< scans that never arrived (ScanLossEstimator)
  double scan_loss_fraction = 0.0;           ///< lost / (received + lost)
  std::int64_t clock_jumps = 0;              ///< data clock jumps followed (scan or pose channel, whichever saw more)
  std::int64_t odometry_resets = 0;          ///< odometry resets bridged (OdometryResetFilter)
  std::int64_t sensor_changes = 0;           ///< sensor layout changes (SensorLayoutWatch)
  std::int64_t keyframes_deskewed = 0;       ///< keyframe scans motion-compensated from their per-point times
  std::int64_t keyframes_submapped = 0;      ///< keyframes whose cloud merged earlier scans (narrow or sparse sensor, submap.*)
  std::int64_t submap_scans = 0;             ///< earlier scans merged into those keyframes, in all
  std::int64_t deskew_skipped = 0;           ///< keyframe scans with times left as they were: poses do not cover the sweep, or too long a sweep
  std::int64_t session = 0;                  ///< the session this run's keyframes go to now
  std::int64_t sessions_opened = 0;          ///< sessions this run opened (another drive, an odometry reset)
  std::int64_t keyframes_skipped = 0;        ///< scans recognised as keyframes the map holds (a replay rerun) and skipped
  std::int64_t loops_revoked = 0;            ///< accepted loops the map's loop ledger keeps out of the graph now
  std::int64_t ledger_corrections = 0;       ///< graph solves made because the ledger changed (running, or at start)
  std::int64_t keyframes_retired = 0;        ///< keyframes this run retired (place density policy; those the map held retired: ResumeSummary)
  double deskew_max_correction = 0.0;        ///< [m] largest distance deskew moved a point
  std::int64_t sweeps_from_scans = 0;        ///< keyframes deskewed with the motion their scans measured (deskew.from_scans)
  std::int64_t sweeps_from_odometry = 0;     ///< keyframes that tried and kept the odometry's motion (scans disagreed, did not register)
  std::int64_t sweeps_shape_refined = 0;     ///< of sweeps_from_scans: with more than one turn rate (refine_sweep_shape)
  std::int64_t sweeps_gyro = 0;              ///< of sweeps_from_scans: bent as the gyro turned through the sweep (SweepBend)
  std::int64_t sweeps_gyro_refused = 0;      ///< sweeps whose gyro turned otherwise than the odometry (mounting, axes, clock): not used
  std::int64_t sweeps_velocity_changed = 0;  ///< of sweeps_from_scans: the previous sweep at its own velocity (the odometry's changed)
  std::string device;
  EngineProfile profile;
};

/// @brief Liveness of the engine's two stages (for the systemd watchdog, see PipelineWatchdog).
struct EngineProgress {
  StageProgress workers;     ///< steps: keyframes whose features were computed (or shed); pending: keyframes queued or in a worker
  StageProgress sequential;  ///< steps: keyframes sequenced and decisions made; pending: a finished keyframe waits to be sequenced
};

/// @brief Scan/pose association, keyframe selection, a worker pool for features and an in-order sequential
///        stage running the LoopDetector. Transport-free: the daemon feeds it from LCM, tests feed it directly.
///        push_* and tick() must be called from one thread.
class LoopdEngine {
 public:
  LoopdEngine(const EngineConfig& config, EngineSink* sink);
  ~LoopdEngine();
  LoopdEngine(const LoopdEngine&) = delete;
  LoopdEngine& operator=(const LoopdEngine&) = delete;

  /// @brief A decoded scan that arrived at `arrival_s` (wall clock live, the logger's receive time in replay).
  ///        Returns false (counted) when it is invalid: empty, all non-finite, too large, duplicate or stale utime.
  bool push_scan(std::int64_t utime, PointCloud cloud, double arrival_s);
  /// @brief A decoded odometry pose. Returns false (counted) for a duplicate or stale utime.
  bool push_pose(const StampedPose& pose, double arrival_s);
  /// @brief A decoded gyro sample. Returns false (counted) unless its utime is later than the last sample's.
  bool push_imu(const ImuSample& sample);
  /// @brief Lets waiting scans time out on the wall clock (live mode); when the sequential stage is idle, the sink's
  /// on_idle() runs (in its place, so never beside it).
  void tick(double wall_time_s);
  /// @brief End of input: associates what it can and waits until every keyframe has been processed.
  void finish();
  EngineStats stats() const;
  /// @brief The current map<-odometry correction (identity before the first loop).
  Eigen::Isometry3d T_map_odom() const;
  /// @brief Before any input: continues from what `store` holds (the detector as it was, keyframe numbering after the
  /// stored ones; corrections the stop cut off are made again and go to the sink). With skip_stored_keyframes (replay
  /// of the same drive) the keyframes the map already holds are recognised by their scan times and not processed again.
  /// `read_only`: the store is never written (resume_detector).
  ResumeSummary resume(MapStore& store, bool skip_stored_keyframes, bool read_only = false);
  /// @brief Before any input and resume(): keyframe features live in `store` and in an LRU cache of `cache_bytes`
  /// (the sequential stage reads candidates back; the store must then be used from that stage only).
  void keep_features_in_store(MapStore& store, std::size_t cache_bytes);
  /// @brief Before any input: workers also reduce each keyframe's (deskewed) scan to its map cloud (config.map_cloud)
  /// and encode it for the sink (the map writer stores it; nothing of it is kept in memory).
  void make_map_clouds() { map_clouds_ = config_.map_cloud.enabled; }
  /// @brief Before any input: other vehicles' keyframes (a fleet on one map), taken by the sequential stage before each
  /// keyframe of this vehicle and added to the detector as candidates (LoopDetector::add_remote_keyframe).
  void set_remote_feed(std::function<std::vector<KeyframeRecord>()> feed) { remote_feed_ = std::move(feed); }
  /// @brief Before any input: the map's loop ledger (runtime/ledger_watch.hpp), asked by the sequential stage before
  /// each keyframe and when idle (tick); when it names other revoked loops, the detector solves its graph again without
  /// them (LoopDetector::set_revoked_loops) and the correction goes to the sink like any other.
  void set_ledger_feed(std::function<std::optional<LedgerState>()> feed) { ledger_feed_ = std::move(feed); }
  /// @brief Keyframes recognised as already in the map and skipped (replay resume).
  std::int64_t keyframes_skipped() const { return keyframes_skipped_.load(); }
  /// @brief How far each stage got and whether work waits for it; callable from any thread.
  EngineProgress progress() const;

 private:
  struct Job {
    std::int64_t sequence = 0;  ///< order of submission: the sequential stage takes keyframes in this order
    KeyframeInput input;
    PointCloud cloud;
    std::vector<StampedPose> sweep_poses;                           ///< T_odom_sensor around the sweep (deskew on, scan with times)
    Eigen::Isometry3d T_odom_scan = Eigen::Isometry3d::Identity();  ///< the scan's odometry pose as received (submap frame)
    std::vector<std::shared_ptr<const WindowScan>> submap;          ///< earlier scans to merge (narrow or sparse sensor)
    std::shared_ptr<const WindowScan> previous;                     ///< the scan before it, for the sweep's motion (deskew_from_scans)
    StampedPose before_previous;                  ///< the odometry's pose at the scan before `previous` (its sweep's motion); utime 0: none
    std::shared_ptr<const WindowScan> raw;        ///< the scan, when shared as the next one's `previous`: the worker copies it into cloud
    std::int64_t sweep_begin = 0, sweep_end = 0;  ///< [us] the first and last point time (the scan's utime without times)
    std::vector<ImuSample> gyro;                  ///< gyro samples over this sweep and the one before it (imu.enabled)
  };
  void handle_associated(std::vector<AssociatedScan> scans);
  /// @brief Whether the odometry moved less than steps.max_unskewed_motion / _rotation_deg since the last scan (a
  ///        scan without times is then free of skew enough to register); remembers the pose.
  bool moved_little_since_last_scan(const Eigen::Isometry3d& T_odom_sensor);
  /// The gyro samples from the last at or before begin_utime to the first at or after end_utime; empty when the
  /// samples kept do not reach over both (ingest thread).
  std::vector<ImuSample> gyro_between(std::int64_t begin_utime, std::int64_t end_utime) const;
  void update_input_health();
  void submit(Job job);
  bool ingest_scan(std::int64_t utime, PointCloud cloud, double arrival_s);
  /// Finished keyframes that may wait for the sequential stage: replay allows 16x queue_capacity (features only,
  /// ~0.1 MB each, and kept afterwards anyway) so the workers run ahead through a stretch of long verifications; live
  /// allows 4x, which bounds how far decisions lag behind the stream.
  int ready_capacity() const { return (config_.block_when_full ? 16 : 4) * config_.queue_capacity; }
  /// No room for another keyframe (queue_mutex_ held): queue_capacity raw scans wait for a worker, or ready_capacity()
  /// finished keyframes wait for the sequential stage.
  bool full() const { return static_cast<int>(queue_.size()) >= config_.queue_capacity || ready_backlog_.load() >= ready_capacity(); }
  void worker_loop();
  /// Deskews the job's scan in place (deskew on, scan with per-point times) and counts what it did.
  /// Deskews the keyframe scan; returns the [ms] spent measuring the sweep motion by the scans.
  double deskew_scan(Job& job);
  /// The earlier scans of a narrow or sparse sensor merged into the keyframe's cloud (after deskew_scan).
  void merge_submap_scans(Job& job);
  /// Keeps a scan in the window of later keyframes' submaps (ingest thread).
  std::shared_ptr<const WindowScan> keep_for_submaps(AssociatedScan scan);
  /// The sweep's motion from the job's scan and the one before it, as two poses for deskew() (empty: keep the odometry's).
  std::vector<StampedPose> sweep_poses_from_scans(const Job& job);
  /// Whether a keyframe's sweep motion used the gyro, or refused it (it turned otherwise than the odometry), and the turns.
  struct GyroUse {
    bool used = false, refused = false;
    double gyro_deg = 0.0, odometry_deg = 0.0, disagreement_deg = 0.0;  ///< the turns, and the angle between the two rotations
  };
  /// The shapes of the job's sweep and of the one before it off their constant-velocity paths, and their rotations,
  /// from the gyro; empty without gyro samples over both sweeps, or when the gyro disagrees with the odometry.
  SweepBends sweep_bends(const Job& job, const Eigen::Isometry3d& odometry_T_previous_current, double dt, bool previous_known, GyroUse* use) const;
  /// Counts a sweep whose gyro was refused; warns once.
  void note_gyro_refused(const GyroUse& use);
  /// The path through a keyframe's sweep: the scans' increment bent as the gyro turned.
  static std::vector<StampedPose> bent_sweep_path(const Job& job, const Eigen::Isometry3d& T_previous_current, double dt, const SweepBend& bend);
  /// True when the scan's sweep began before the first of its poses (deskew would extrapolate the motion backwards).
  static bool sweep_begins_before_poses(const AssociatedScan& scan);
  /// Logs what a keyframe's scan showed of the lidar when it differs from what was last logged (a few times at
  /// most), and a configured preset that does not fit the scans (once); then drops the notes from the features.
  void note_sensor(KeyframeFeatures& features);
  /// A keyframe done by a worker (or shed), waiting for the sequential stage.
  struct ReadyKeyframe {
    KeyframeInput input;
    std::shared_ptr<const KeyframeFeatures> features;
    MapCloudBlob map_cloud;
  };
  void complete(std::int64_t sequence, ReadyKeyframe keyframe);
  /// @brief Sequences the ready keyframes in order unless another thread is (`lock` holds sequence_mutex_).
  void sequence_ready(std::unique_lock<std::mutex>& lock);
  void run_sequential(ReadyKeyframe& item);
  /// After a keyframe that closed a loop: the place density policy's retirements, to the detector and the sink.
  void retire_redundant(const ReadyKeyframe& item, const DetectorOutput& out);
  /// Keyframes of sessions before this one are never retired (a map opened read-only: --localize); 0: any may be.
  SessionId retirable_from_session_ = 0;

  EngineConfig config_;
  EngineSink* sink_;
  ScanPoseAssociator associator_;
  // Input health, all on the ingest thread: clocks per channel, odometry resets, scan loss, sensor layout.
  ClockWatch scan_clock_, pose_clock_;
  OdometryResetFilter odometry_filter_;
  ScanLossEstimator loss_;
  SensorLayoutWatch layout_;
  KeyframeSelector selector_;
  LoopDetector detector_;
  SessionKeys session_keys_;  ///< session and index of each keyframe (ingest thread)
  std::int64_t next_sequence_ = 0;
  bool features_in_store_ = false;
  std::function<std::vector<KeyframeRecord>()> remote_feed_;
  std::function<std::optional<LedgerState>()> ledger_feed_;
  /// The ledger's news, applied to the detector (sequential stage).
  void apply_ledger();
  bool map_clouds_ = false;
  std::atomic<std::int64_t> keyframes_skipped_{0};
  double residual_since_keyframe_ = 0.0;
  double submit_wait_ms_ = 0.0;  ///< [ms] the ingest thread waited for room in the worker queue (its own counter)

  mutable std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::condition_variable space_cv_;
  std::deque<Job> queue_;
  int busy_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> workers_;

  // Finished keyframes wait in ready_ until every earlier one is sequenced. One thread at a time runs the sequential
  // stage (sequencing_); a worker that finishes meanwhile leaves its keyframe here and goes back to the queue
  // instead of waiting for the lock, so both cores stay busy while a loop is verified.
  std::mutex sequence_mutex_;
  std::map<std::int64_t, ReadyKeyframe> ready_;
  bool sequencing_ = false;
  std::atomic<int> ready_backlog_{0};  ///< ready_.size(), readable without sequence_mutex_ (bounded by ready_capacity())
  std::int64_t next_to_sequence_ = 0;
  std::condition_variable done_cv_;
  std::mutex done_mutex_;
  std::atomic<std::int64_t> sequenced_{0};
  // Progress (progress()): keyframes handed to complete() and steps of each stage.
  std::atomic<std::int64_t> completed_{0};
  std::atomic<std::int64_t> worker_steps_{0};
  std::atomic<std::int64_t> sequential_steps_{0};

  ScanWindow scan_window_;                           ///< (ingest thread) recent scans of a narrow or sparse sensor
  std::optional<Eigen::Isometry3d> last_scan_pose_;  ///< (ingest thread) the last scan's odometry pose
  StampedPose pose_before_previous_;                 ///< (ingest thread) the odometry pose of the scan before previous_scan_; utime 0: none
  std::shared_ptr<const WindowScan> previous_scan_;  ///< (ingest thread) the last scan with per-point times (deskew_from_scans)
  std::deque<ImuSample> imu_;                        ///< (ingest thread) the last second of gyro samples
  mutable std::mutex stats_mutex_;
  std::string sensor_logged_;                              ///< (under stats_mutex_) the last logged sensor layout's rings or rows
  int sensor_notes_ = 0;                                   ///< (under stats_mutex_) layout notes logged
  static constexpr std::int64_t kLayoutCheckedFirst = 20;  ///< keyframes whose layout is always checked (with a preset)
  static constexpr std::int64_t kLayoutCheckEvery = 10;    ///< then every this many
  std::atomic<std::int64_t> layout_checks_{0};             ///< keyframes the workers started (turns of the layout check)
  bool sensor_mismatch_logged_ = false;
  EngineStats stats_;
  Eigen::Isometry3d T_map_odom_ = Eigen::Isometry3d::Identity();
};

}  // namespace loopd
