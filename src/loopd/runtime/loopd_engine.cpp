#include "loopd/runtime/loopd_engine.hpp"

#include "loopd/base/stopwatch.hpp"

#include "loopd/base/scan_fingerprint.hpp"
#include "loopd/base/scene_scale.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <pthread.h>
#include <string>

#include "loopd/runtime/heap_release.hpp"
#include "loopd/store/map_cloud_codec.hpp"
#include "loopd/base/angles.hpp"
#include "loopd/runtime/log_level.hpp"

namespace loopd {
namespace {
/// R_sensor_imu of imu.rpy_deg.
Eigen::Matrix3d imu_rotation(const EngineConfig::Imu& imu) { return rotation_from_rpy_deg(imu.rpy_deg[0], imu.rpy_deg[1], imu.rpy_deg[2]); }

/// PoCL's kernel compiler: ~70 MB of resident code after the kernels are built, idle while loopd detects loops.
const std::vector<std::string> kCompilerLibraries{"libLLVM", "libclang-cpp"};
}  // namespace

std::optional<std::string> EngineConfig::validate() const {
  if (auto e = association.validate()) return e;
  if (auto e = deskew.validate()) return e;
  if (auto e = sweep_motion.validate()) return "deskew from scans: " + *e;
  if (auto e = submap.validate()) return e;
  if (auto e = detector.validate()) return e;
  if (num_threads < 0) return "num_threads must be >= 0 (0 = hardware threads)";
  if (queue_capacity < 1) return "queue_capacity must be >= 1";
  if (max_points_per_scan < 1) return "max_points_per_scan must be >= 1";
  if (!(clock_jump > 0.0)) return "input.clock_jump must be > 0 [s]";
  if (!(max_odometry_speed > 0.0)) return "input.max_odometry_speed must be > 0 [m/s]";
  if (auto e = sessions.validate()) return e;
  if (auto e = map_cloud.validate()) return e;
  if (auto e = retirement.validate()) return e;
  if (imu.rpy_deg.size() != 3) return "imu.rpy_deg must hold 3 angles (roll, pitch, yaw) [deg]";
  for (const double a : imu.rpy_deg)
    if (!(std::abs(a) <= 360.0)) return "imu.rpy_deg: angles must be finite and within +-360 deg";
  if (!(imu.max_gap > 0.0 && imu.max_gap <= 1.0)) return "imu.max_gap must be in (0, 1] s";
  return std::nullopt;
}

LoopdEngine::LoopdEngine(const EngineConfig& config, EngineSink* sink)
    : config_(config),
      sink_(sink),
      associator_(config.association, config.deskew.enabled),
      scan_clock_(ClockWatch::Config{config.clock_jump, 2}),
      pose_clock_(ClockWatch::Config{config.clock_jump, 2}),
      odometry_filter_(OdometryResetFilter::Config{config.max_odometry_speed, 360.0, 2.0}),
      selector_(config.detector.keyframe),
      detector_(config.detector),
      session_keys_([&config] {
        SessionPolicy policy = config.sessions;
        policy.max_speed = config.max_odometry_speed;
        return policy;
      }()),
      scan_window_(config.submap) {
  int n = config_.num_threads > 0 ? config_.num_threads : static_cast<int>(std::thread::hardware_concurrency());
  if (n < 1) n = 1;
  stats_.device = detector_.descriptor_device();
  page_out_library_code(kCompilerLibraries);  // the M2DP kernels are built: PoCL's compiler is idle from here on
  for (int i = 0; i < n; ++i)
    workers_.emplace_back([this, i] {
      const std::string name = "loopd-worker" + std::to_string(i);  // what top -H and gdb show
      pthread_setname_np(pthread_self(), name.c_str());
      worker_loop();
    });
}

LoopdEngine::~LoopdEngine() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stopping_ = true;
  }
  queue_cv_.notify_all();
  space_cv_.notify_all();
  for (auto& t : workers_) t.join();
}

bool LoopdEngine::push_scan(std::int64_t utime, PointCloud cloud, double arrival_s) {
  const Stopwatch sw;
  const double waited_before = submit_wait_ms_;
  const bool accepted = ingest_scan(utime, std::move(cloud), arrival_s);
  const double ms = sw.ms() - (submit_wait_ms_ - waited_before);
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.profile.ingest_ms += ms;
  return accepted;
}

bool LoopdEngine::ingest_scan(std::int64_t utime, PointCloud cloud, double arrival_s) {
  std::size_t finite = 0;
  for (const auto& p : cloud.points) finite += p.allFinite() ? 1u : 0u;
  const bool too_large = static_cast<std::int64_t>(cloud.size()) > config_.max_points_per_scan;
  const ClockVerdict verdict = (finite == 0 || too_large) ? ClockVerdict::kStale : scan_clock_.check(utime, arrival_s);
  const bool jumped = verdict == ClockVerdict::kJumpBack || verdict == ClockVerdict::kJumpForward;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.scans_in;
    stats_.nan_points += static_cast<std::int64_t>(cloud.size() - finite);
    if (finite == 0 || too_large || verdict == ClockVerdict::kStale) {
      ++stats_.invalid_scans;
      if (verdict == ClockVerdict::kStale && !too_large && finite > 0) loss_.on_late_scan(utime);  // late, not lost
    }
  }
  if (finite == 0 || too_large || verdict == ClockVerdict::kStale) {
    update_input_health();
    return false;
  }
  if (verdict == ClockVerdict::kJumpBack) associator_.restart_scans();
  loss_.on_scan(utime, jumped);
  layout_.on_scan(static_cast<std::int64_t>(cloud.size()), cloud.num_rings);
  update_input_health();
  if (!associator_.add_scan(utime, std::move(cloud), arrival_s)) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.invalid_scans;
    return false;
  }
  handle_associated(associator_.poll(arrival_s, !config_.block_when_full));
  return true;
}

bool LoopdEngine::push_pose(const StampedPose& raw, double arrival_s) {
  const ClockVerdict verdict = pose_clock_.check(raw.utime, arrival_s);
  if (verdict == ClockVerdict::kStale) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.poses_in;
    ++stats_.invalid_poses;
    return false;
  }
  const bool jumped = verdict == ClockVerdict::kJumpBack || verdict == ClockVerdict::kJumpForward;
  if (verdict == ClockVerdict::kJumpBack) associator_.restart_poses();
  if (jumped) odometry_filter_.forget_last();  // times across a jump cannot be compared
  bool reset = false;
  const StampedPose pose = odometry_filter_.apply(raw, &reset);
  if (reset) session_keys_.on_odometry_reset(raw.utime, odometry_filter_.T_continuous_odom());
  loss_.on_pose(pose.utime, jumped);
  update_input_health();
  const bool ok = associator_.add_pose(pose);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.poses_in;
    if (!ok) ++stats_.invalid_poses;
  }
  handle_associated(associator_.poll(arrival_s, !config_.block_when_full));
  return ok;
}

bool LoopdEngine::push_imu(const ImuSample& sample) {
  const bool ok = imu_.empty() || sample.utime > imu_.back().utime;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.imu_in;
    if (!ok) ++stats_.invalid_imu;
  }
  if (!ok || !config_.imu.enabled) return ok;
  imu_.push_back(sample);
  constexpr std::int64_t kKeptUs = 1000000;  // a second: two sweeps at 2 Hz
  while (!imu_.empty() && imu_.front().utime < sample.utime - kKeptUs) imu_.pop_front();
  return ok;
}

std::vector<ImuSample> LoopdEngine::gyro_between(std::int64_t begin_utime, std::int64_t end_utime) const {
  if (imu_.empty() || imu_.front().utime > begin_utime || imu_.back().utime < end_utime) return {};  // not covered
  const auto by_time = [](const ImuSample& a, std::int64_t t) { return a.utime < t; };
  auto first = std::lower_bound(imu_.begin(), imu_.end(), begin_utime, by_time);
  if (first->utime > begin_utime) --first;                                    // the last sample at or before the beginning
  const auto last = std::lower_bound(first, imu_.end(), end_utime, by_time);  // the first at or after the end
  return std::vector<ImuSample>(first, last + 1);
}

void LoopdEngine::update_input_health() {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.scans_lost_estimate = loss_.lost();
  stats_.scan_loss_fraction = loss_.loss_fraction();
  stats_.clock_jumps = std::max(scan_clock_.jumps(), pose_clock_.jumps());
  stats_.odometry_resets = odometry_filter_.resets();
  stats_.sensor_changes = layout_.changes();
}

void LoopdEngine::tick(double wall_time_s) {
  handle_associated(associator_.poll(wall_time_s, !config_.block_when_full));
  {
    std::lock_guard<std::mutex> lock(sequence_mutex_);
    if (sequencing_) return;  // busy: it calls the sink anyway
    sequencing_ = true;       // the sink is this thread's until it gives the role back
  }
  apply_ledger();
  sink_->on_idle();
  // Keyframes that became ready meanwhile waited for the role: sequence them as complete() would have.
  std::unique_lock<std::mutex> lock(sequence_mutex_);
  sequencing_ = false;
  sequence_ready(lock);
}

bool LoopdEngine::moved_little_since_last_scan(const Eigen::Isometry3d& T_odom_sensor) {
  const Eigen::Isometry3d motion = last_scan_pose_ ? last_scan_pose_->inverse() * T_odom_sensor : Eigen::Isometry3d::Identity();
  const bool little = last_scan_pose_ && motion.translation().norm() < config_.detector.steps.max_unskewed_motion &&
                      rotation_angle(motion) * 180.0 / M_PI < config_.detector.steps.max_unskewed_rotation_deg;
  last_scan_pose_ = T_odom_sensor;
  return little;
}

void LoopdEngine::handle_associated(std::vector<AssociatedScan> scans) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.dropped_no_pose = associator_.dropped_no_pose();
    stats_.pending_scans = static_cast<int>(associator_.pending());
  }
  const bool sweeps_from_scans = config_.deskew.enabled && config_.deskew_from_scans;
  for (auto& s : scans) {
    residual_since_keyframe_ += s.residual_sum;
    // The scan before a keyframe measures the keyframe's sweep motion with it (deskew_from_scans).
    std::shared_ptr<const WindowScan> previous = std::move(previous_scan_);
    // The odometry's pose at the scan before that one: the previous sweep's own motion.
    const StampedPose before_previous = pose_before_previous_;
    pose_before_previous_ = previous ? StampedPose{previous->utime, previous->T_odom_sensor, 0.0} : StampedPose{};
    bool timed = sweeps_from_scans && s.cloud.has_time();
    // A narrow or sparse sensor: every scan is kept a moment for the next keyframe's submap.
    const bool narrow = scan_window_.update_mode(needs_submap(s.cloud, config_.submap));
    // A sweep that began before the first pose (the drive's first scan) could only be deskewed by guessing the motion
    // before the odometry: the next scan, measured throughout, makes a better first keyframe.
    const bool before_odometry = config_.deskew.enabled && s.cloud.has_time() && sweep_begins_before_poses(s);
    const bool slow_sweep = moved_little_since_last_scan(s.pose.T_world_sensor) || (config_.compensated_upstream && !s.cloud.has_time());
    if (before_odometry) timed = false;  // nor the sweep-motion reference of the next one: its motion is not known
    if (before_odometry || !selector_.accept(s.pose.T_world_sensor, s.utime, [&s] { return scene_scale(s.cloud); })) {
      if (narrow) {
        auto kept = keep_for_submaps(std::move(s));
        if (timed) previous_scan_ = std::move(kept);
      } else if (timed) {  // only what the next keyframe's sweep motion reads: queued jobs hold it beside their scan
        previous_scan_ =
            std::make_shared<const WindowScan>(WindowScan{s.utime, sweep_motion_input(s.cloud, config_.sweep_motion), s.pose.T_world_sensor, {}});
      }
      continue;
    }
    // The keyframe's raw scan is also the next scan's sweep-motion reference: shared, and copied by the worker that
    // deskews it rather than here on the ingest thread (a narrow sensor's window keeps its own copy below).
    std::shared_ptr<const WindowScan> raw;
    if (timed && !narrow) {
      raw = std::make_shared<const WindowScan>(WindowScan{s.utime, std::move(s.cloud), s.pose.T_world_sensor, {}});
      previous_scan_ = raw;
    } else if (timed) {
      previous_scan_ =
          std::make_shared<const WindowScan>(WindowScan{s.utime, sweep_motion_input(s.cloud, config_.sweep_motion), s.pose.T_world_sensor, {}});
    }
    const std::uint64_t fingerprint = scan_fingerprint(raw ? raw->cloud : s.cloud);
    SessionKeys::Assigned assigned = session_keys_.assign(s.utime, s.pose.T_world_sensor, fingerprint);
    if (!assigned.note.empty() && log_enabled(LogLevel::kInfo)) std::fprintf(stderr, "loopd: %s\n", assigned.note.c_str());
    if (assigned.stored) ++keyframes_skipped_;
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      stats_.session = assigned.key.session;
      stats_.sessions_opened = session_keys_.sessions_opened();
      stats_.keyframes_skipped = keyframes_skipped_.load();
    }
    if (assigned.stored) {
      residual_since_keyframe_ = 0.0;
      if (narrow) keep_for_submaps(std::move(s));  // the next keyframes' submaps hold it, as in the run that stored it
      continue;
    }
    Job job;
    job.sequence = next_sequence_++;
    job.input.key = assigned.key;
    job.input.utime = s.utime;
    job.input.T_odom_sensor = assigned.T_odom_sensor;
    job.input.residual = residual_since_keyframe_;
    job.input.scan_fingerprint = fingerprint;
    job.input.motion_compensated = slow_sweep;  // the worker sets it where it deskews the scan
    residual_since_keyframe_ = 0.0;
    job.T_odom_scan = s.pose.T_world_sensor;
    job.previous = std::move(previous);
    job.before_previous = before_previous;
    if (config_.imu.enabled && job.previous && !imu_.empty()) {  // over both sweeps: this one and the reference's
      const std::int64_t reference_begin = before_previous.utime != 0 ? before_previous.utime : job.previous->utime - (s.utime - job.previous->utime);
      job.gyro = gyro_between(reference_begin, s.utime);
    }
    if (narrow) {
      job.submap = scan_window_.recent(s.utime, s.pose.T_world_sensor);
      keep_for_submaps(s);  // a copy: the keyframe's scan belongs to the next keyframes' windows too
    }
    if (raw)
      job.raw = std::move(raw);
    else
      job.cloud = std::move(s.cloud);
    job.sweep_begin = s.sweep_begin;
    job.sweep_end = s.sweep_end;
    job.sweep_poses = std::move(s.sweep_poses);
    submit(std::move(job));
  }
}

ResumeSummary LoopdEngine::resume(MapStore& store, bool skip_stored_keyframes, bool read_only) {
  // Planes need every keyframe's segmentation back; otherwise descriptors suffice when the store keeps the features.
  const bool thin = features_in_store_ && !config_.detector.correction.graph.use_plane_constraints;
  ResumeSummary r = resume_detector(store, detector_, thin ? KeyframeLoad::kDescriptor : KeyframeLoad::kFull, read_only);
  if (!r.ok) return r;
  // A read-only map's keyframes are never retired (only this run's own, where the map already holds the place).
  if (read_only)
    for (const StoredKeyframe& k : r.stored) retirable_from_session_ = std::max(retirable_from_session_, k.key.session + 1);
  session_keys_.restore(r.stored, skip_stored_keyframes);
  for (const CorrectionOutput& c : r.corrections) sink_->on_correction(c);
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.loops_revoked = r.loops_revoked;
  stats_.ledger_corrections = r.ledger_corrected ? 1 : 0;
  stats_.keyframes = static_cast<std::int64_t>(detector_.num_keyframes());
  stats_.loops_accepted = detector_.loops_accepted();
  stats_.loops_rejected = detector_.loops_rejected();
  return r;
}

void LoopdEngine::keep_features_in_store(MapStore& store, std::size_t cache_bytes) {
  features_in_store_ = true;
  detector_.keep_features_in_store(cache_bytes, [&store](const KeyframeKey& key) -> std::optional<PreparedScan> {
    StoreResult<PreparedScan> read = store.get_prepared(key);
    if (!read.ok()) return std::nullopt;
    return std::move(read.value);
  });
}

void LoopdEngine::submit(Job job) {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  const Stopwatch waiting;
  if (config_.block_when_full) {
    space_cv_.wait(lock, [&] { return !full() || stopping_; });
  } else {
    // Live. The sequential stage far behind (a long verification): wait for it rather than pile up keyframes; the
    // LCM thread keeps receiving into its own bounded input queue meanwhile.
    space_cv_.wait(lock, [&] { return ready_backlog_.load() < ready_capacity() || stopping_; });
  }
  submit_wait_ms_ += waiting.ms();  // the ingest thread's own counter (EngineProfile::ingest_ms leaves it out)
  if (!config_.block_when_full && static_cast<int>(queue_.size()) >= config_.queue_capacity) {
    // Load shedding (live): the oldest waiting keyframe keeps its pose but skips features and verification.
    Job shed = std::move(queue_.front());
    queue_.pop_front();
    lock.unlock();
    {
      std::lock_guard<std::mutex> s(stats_mutex_);
      ++stats_.shed;
    }
    worker_steps_.fetch_add(1);
    complete(shed.sequence, ReadyKeyframe{shed.input, nullptr, nullptr});
    lock.lock();
  }
  queue_.push_back(std::move(job));
  lock.unlock();
  queue_cv_.notify_one();
}

void LoopdEngine::worker_loop() {
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;  // shutdown: queued keyframes are abandoned (finish() drains them first in replay)
      job = std::move(queue_.front());
      queue_.pop_front();
      ++busy_;
    }
    space_cv_.notify_one();
    Stopwatch sw;
    if (job.raw) {
      job.cloud = job.raw->cloud;
      job.raw.reset();
    }
    // With a preset, the layout it is checked against is read before deskew moves the points (not an extra cost: the
    // detector then reads none from the deskewed scan).
    const Stopwatch layout_sw;
    // With a preset the layout is only checked against it: on the first keyframes and every tenth after them (a
    // sensor swapped mid-run is counted on ingest; its layout shows within ten keyframes).
    const std::int64_t layout_turn = layout_checks_.fetch_add(1);
    const bool check_layout = layout_turn < kLayoutCheckedFirst || layout_turn % kLayoutCheckEvery == 0;
    std::optional<SensorEstimate> measured_layout;
    if (check_layout && detector_.has_sensor_preset() && config_.deskew.enabled && job.cloud.has_time()) measured_layout = estimate_sensor(job.cloud);
    const double layout_ms = layout_sw.ms();  // the features' work (the profile's "prepare"), done before deskew
    const double sweep_motion_ms = deskew_scan(job);
    merge_submap_scans(job);
    const double deskew_ms = sw.ms() - sweep_motion_ms - layout_ms;
    sw.reset();
    auto features =
        std::make_shared<KeyframeFeatures>(detector_.compute_features(job.cloud, measured_layout ? &*measured_layout : nullptr, check_layout));
    note_sensor(*features);
    const double features_ms = sw.ms() + layout_ms;
    sw.reset();
    MapCloudBlob map_cloud;
    if (map_clouds_)
      map_cloud = std::make_shared<const std::vector<std::uint8_t>>(
          encode_map_cloud(reduce_to_map_cloud(job.cloud, config_.map_cloud), config_.map_cloud.quantum, config_.map_cloud.zstd_level));
    const double map_cloud_ms = sw.ms();
    job.cloud = PointCloud();
    worker_steps_.fetch_add(1);
    {
      std::lock_guard<std::mutex> s(stats_mutex_);
      if (!features->ok) ++stats_.feature_failures;
      EngineProfile& p = stats_.profile;
      p.sweep_motion_ms += sweep_motion_ms;
      p.deskew_ms += deskew_ms;
      p.descriptor_ms += features->ms_descriptor;
      p.prepare_ms += features_ms - features->ms_descriptor;
      p.map_cloud_ms += map_cloud_ms;
      ++p.keyframes_prepared;
    }
    complete(job.sequence, ReadyKeyframe{job.input, features, std::move(map_cloud)});
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      --busy_;
    }
  }
}

void LoopdEngine::note_sensor(KeyframeFeatures& f) {
  constexpr int kMaxLayoutNotes = 5;
  // The layout up to its angles ("64 rings", "no ring pattern: 64 rows"): angles move by a tenth of a degree a scan.
  const std::string layout = f.sensor_layout.substr(0, std::min(f.sensor_layout.find(" between"), f.sensor_layout.find(" over")));
  std::string log_layout, log_mismatch;
  {
    std::lock_guard<std::mutex> s(stats_mutex_);
    if (!f.sensor_layout.empty() && layout != sensor_logged_ && sensor_notes_ < kMaxLayoutNotes) {
      sensor_logged_ = layout;
      log_layout = f.sensor_layout + (++sensor_notes_ == kMaxLayoutNotes ? " (further layout notes are not logged)" : "");
    }
    if (!f.sensor_mismatch.empty() && !sensor_mismatch_logged_) {
      sensor_mismatch_logged_ = true;
      log_mismatch = f.sensor_mismatch;
    }
  }
  if (!log_layout.empty() && log_enabled(LogLevel::kInfo))
    std::fprintf(stderr, "loopd: sensor (%s): %s\n", config_.detector.sensor.c_str(), log_layout.c_str());
  if (!log_mismatch.empty())
    std::fprintf(stderr, "loopd: WARNING: %s (the preset is used as given; --sensor auto reads the rings from the scans)\n", log_mismatch.c_str());
  f.sensor_layout.clear();
  f.sensor_layout.shrink_to_fit();
  f.sensor_mismatch.clear();
  f.sensor_mismatch.shrink_to_fit();
}

std::shared_ptr<const WindowScan> LoopdEngine::keep_for_submaps(AssociatedScan s) {
  auto kept = std::make_shared<WindowScan>();
  kept->utime = s.utime;
  kept->cloud = std::move(s.cloud);
  kept->T_odom_sensor = s.pose.T_world_sensor;
  kept->sweep_poses = std::move(s.sweep_poses);
  scan_window_.push(kept);
  return kept;
}

void LoopdEngine::merge_submap_scans(Job& job) {
  if (job.submap.empty()) return;
  const int merged = merge_submap(job.submap, job.T_odom_scan, config_.deskew, &job.cloud);
  job.submap = {};
  std::lock_guard<std::mutex> s(stats_mutex_);
  ++stats_.keyframes_submapped;
  stats_.submap_scans += merged;
}

bool LoopdEngine::sweep_begins_before_poses(const AssociatedScan& s) { return !s.sweep_poses.empty() && s.sweep_poses.front().utime > s.sweep_begin; }

std::vector<StampedPose> LoopdEngine::sweep_poses_from_scans(const Job& job) {
  const std::shared_ptr<const WindowScan>& prev = job.previous;
  if (!prev || !prev->cloud.has_time()) return {};
  const double dt = static_cast<double>(job.input.utime - prev->utime) * 1e-6;
  if (!(dt > 0.0) || dt > config_.deskew.max_pose_gap) return {};  // not the scan just before it (a scan lost between)
  if (job.sweep_begin == job.sweep_end) return {};                 // an instantaneous scan
  // Odometry with poses inside the sweep (an IMU-rate pose stream) already follows the motion through the sweep.
  for (const StampedPose& p : job.sweep_poses)
    if (p.utime > job.sweep_begin && p.utime < job.sweep_end) return {};
  const Eigen::Isometry3d odometry_T_previous_current = prev->T_odom_sensor.inverse() * job.T_odom_scan;
  std::optional<SweepIncrement> odometry_previous_sweep;
  if (job.before_previous.utime != 0) {
    const double dt_previous = static_cast<double>(prev->utime - job.before_previous.utime) * 1e-6;
    if (dt_previous > 0.0 && dt_previous <= config_.deskew.max_pose_gap)
      odometry_previous_sweep = SweepIncrement{job.before_previous.T_world_sensor.inverse() * prev->T_odom_sensor, dt_previous};
  }
  GyroUse gyro;
  const SweepBends bends = sweep_bends(job, odometry_T_previous_current, dt, odometry_previous_sweep.has_value(), &gyro);
  if (gyro.refused) note_gyro_refused(gyro);
  const SweepMotionResult m =
      estimate_sweep_motion(prev->cloud, job.cloud, dt, odometry_T_previous_current, config_.sweep_motion, odometry_previous_sweep, bends);
  {
    std::lock_guard<std::mutex> s(stats_mutex_);
    ++(m.refined ? stats_.sweeps_from_scans : stats_.sweeps_from_odometry);
    if (m.refined && m.velocity_changed) ++stats_.sweeps_velocity_changed;
    if (m.shape_refined) ++stats_.sweeps_shape_refined;
    if (m.bent) ++stats_.sweeps_gyro;
  }
  if (!m.refined) return {};
  if (m.bent) return bent_sweep_path(job, m.T_previous_current, dt, bends.current);
  if (m.shape_refined) {  // the path through the sweep at its knots, anchored at the odometry's pose at the stamp
    const Eigen::Isometry3d T_odom_previous = job.T_odom_scan * m.T_previous_current.inverse();
    std::vector<StampedPose> path{{job.input.utime, job.T_odom_scan, 0.0}};
    for (std::size_t k = 0; k < m.knot_times.size(); ++k)
      path.push_back({job.input.utime + std::llround(m.knot_times[k] * 1e6), T_odom_previous * m.T_previous_knot[k], 0.0});
    // Sorted by time; a knot at the stamp's microsecond gives way to the stamp's own pose (first in the list).
    std::stable_sort(path.begin(), path.end(), [](const StampedPose& a, const StampedPose& b) { return a.utime < b.utime; });
    path.erase(std::unique(path.begin(), path.end(), [](const StampedPose& a, const StampedPose& b) { return a.utime == b.utime; }), path.end());
    return path;
  }
  StampedPose a, b;
  a.utime = prev->utime;
  a.T_world_sensor = job.T_odom_scan * m.T_previous_current.inverse();
  b.utime = job.input.utime;
  b.T_world_sensor = job.T_odom_scan;
  return {a, b};
}

SweepBends LoopdEngine::sweep_bends(const Job& job, const Eigen::Isometry3d& odometry_T_previous_current, double dt, bool previous_known,
                                    GyroUse* use) const {
  const WindowScan& prev = *job.previous;
  // The gyro's rotations, dead-reckoned at the odometry's speed through this sweep (the path curves as it turns).
  const Eigen::Vector3d body_velocity = odometry_T_previous_current.translation() / dt;
  const std::vector<StampedPose> gyro = integrate_gyro(job.gyro, imu_rotation(config_.imu), config_.imu.max_gap, body_velocity);
  SweepBends bends;
  if (gyro.empty() || gyro.back().utime < job.input.utime) return bends;
  const auto turned = gyro_rotation(gyro, prev.utime, job.input.utime, config_.imu.max_gap);
  if (!turned) return bends;
  // A gyro that turned otherwise than the odometry over the sweep (by more than the odometry's step noise, 0.5 deg, and
  // a quarter of the turn) is mounted otherwise than imu.rpy_deg says, or its clock or axes are wrong: not used.
  use->gyro_deg = rotation_angle(Eigen::Isometry3d(*turned)) * 180.0 / kPi;
  use->odometry_deg = rotation_angle(odometry_T_previous_current) * 180.0 / kPi;
  use->disagreement_deg = Eigen::AngleAxisd(turned->transpose() * odometry_T_previous_current.linear()).angle() * 180.0 / kPi;
  if (use->disagreement_deg > 0.5 + 0.25 * use->odometry_deg) {
    use->refused = true;
    return bends;
  }
  use->used = true;
  const double gap = config_.deskew.max_pose_gap;
  bends.current = SweepBend::from_poses(gyro, job.input.utime, dt, gap);
  bends.current_rotation = turned;
  if (!previous_known) return bends;
  const double dt_previous = static_cast<double>(prev.utime - job.before_previous.utime) * 1e-6;
  bends.previous = SweepBend::from_poses(gyro, prev.utime, dt_previous, gap);
  bends.previous_rotation = gyro_rotation(gyro, job.before_previous.utime, prev.utime, config_.imu.max_gap);
  return bends;
}

void LoopdEngine::note_gyro_refused(const GyroUse& use) {
  std::int64_t refused = 0;
  {
    std::lock_guard<std::mutex> s(stats_mutex_);
    refused = ++stats_.sweeps_gyro_refused;
  }
  if (refused == 1 && log_enabled(LogLevel::kWarn))
    std::fprintf(stderr,
                 "loopd: WARNING: over a sweep the gyro on IMU turned %.2f deg and the odometry %.2f deg, about axes %.2f deg apart: its "
                 "mounting (imu.rpy_deg), axes or clock may be wrong; such sweeps are deskewed without it (counted)\n",
                 use.gyro_deg, use.odometry_deg, use.disagreement_deg);
}

std::vector<StampedPose> LoopdEngine::bent_sweep_path(const Job& job, const Eigen::Isometry3d& T_previous_current, double dt, const SweepBend& bend) {
  // At every sample of the bend: the scans' increment at a constant velocity, bent as the gyro turned; anchored at the
  // odometry's pose at the stamp.
  std::vector<StampedPose> path;
  path.reserve(bend.times().size());
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  for (const double t : bend.times()) {
    const Eigen::Isometry3d T = job.T_odom_scan * interpolate_screw(I, T_previous_current, t / dt) * bend.at(t);
    path.push_back({job.input.utime + std::llround(t * 1e6), T, 0.0});
  }
  path.back().T_world_sensor = job.T_odom_scan;
  return path;
}

double LoopdEngine::deskew_scan(Job& job) {
  if (!job.cloud.has_time()) return 0.0;  // scans without times stay as they came, bit for bit
  if (!config_.deskew.enabled) {
    const auto [first, last] = time_span(job.cloud);
    if (first == 0.0 && last == 0.0) job.input.motion_compensated = true;  // an instantaneous scan: free of skew anyway
    return 0.0;
  }
  double sweep_motion_ms = 0.0;
  if (config_.deskew_from_scans) {
    const Stopwatch sw;
    std::vector<StampedPose> measured = sweep_poses_from_scans(job);
    sweep_motion_ms = sw.ms();
    if (!measured.empty()) job.sweep_poses = std::move(measured);
  }
  job.previous.reset();
  const DeskewResult r = deskew(config_.deskew, job.sweep_poses, job.input.utime, &job.cloud);
  job.sweep_poses = {};
  if (r.applied() || r.skipped == DeskewSkip::kNoSpan) job.input.motion_compensated = true;
  if (r.skipped == DeskewSkip::kNoSpan) return sweep_motion_ms;  // an instantaneous scan: nothing to correct
  std::lock_guard<std::mutex> s(stats_mutex_);
  if (r.applied()) {
    ++stats_.keyframes_deskewed;
    stats_.deskew_max_correction = std::max(stats_.deskew_max_correction, r.max_correction);
  } else {
    ++stats_.deskew_skipped;
  }
  return sweep_motion_ms;
}

void LoopdEngine::complete(std::int64_t sequence, ReadyKeyframe keyframe) {
  std::unique_lock<std::mutex> lock(sequence_mutex_);
  ready_.emplace(sequence, std::move(keyframe));
  completed_.fetch_add(1);
  ready_backlog_.store(static_cast<int>(ready_.size()));
  sequence_ready(lock);
}

void LoopdEngine::sequence_ready(std::unique_lock<std::mutex>& lock) {
  if (sequencing_) return;  // the thread that is sequencing takes it (checked and cleared under the same lock)
  sequencing_ = true;
  // The sequential stage runs strictly in keyframe order, so live and replay runs make the same decisions.
  while (!ready_.empty() && ready_.begin()->first == next_to_sequence_) {
    ReadyKeyframe item = std::move(ready_.begin()->second);
    ready_.erase(ready_.begin());
    ready_backlog_.store(static_cast<int>(ready_.size()));
    lock.unlock();
    {
      std::lock_guard<std::mutex> q(queue_mutex_);  // a blocked submit() may now have room
    }
    space_cv_.notify_one();
    run_sequential(item);
    lock.lock();
    ++next_to_sequence_;
    sequential_steps_.fetch_add(1);
    sequenced_.fetch_add(1);
  }
  sequencing_ = false;
  lock.unlock();
  done_cv_.notify_all();
}

void LoopdEngine::apply_ledger() {
  if (!ledger_feed_) return;
  const std::optional<LedgerState> ledger = ledger_feed_();
  if (!ledger) return;
  const std::optional<CorrectionOutput> c = detector_.set_revoked_loops(ledger->revoked, ledger->ledger_seq);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.loops_revoked = static_cast<std::int64_t>(detector_.revoked_loops());
    if (c) ++stats_.ledger_corrections;
  }
  if (!c) return;
  sink_->on_correction(*c);
  release_free_heap();  // after a whole-graph solve, as after any
}

void LoopdEngine::run_sequential(ReadyKeyframe& item) {
  apply_ledger();
  // Other vehicles' keyframes read since the last keyframe become candidates first (a fleet on one map).
  if (remote_feed_)
    for (KeyframeRecord& remote : remote_feed_()) detector_.add_remote_keyframe(std::move(remote));
  // Each decision goes out as soon as it is made; an accepted loop's correction follows.
  const Stopwatch sw;
  double verify_ms = 0.0;
  DetectorOutput out = detector_.add_keyframe(
      item.input, item.features,
      [this, &verify_ms](const LoopDecision& d) {
        verify_ms += d.ms_total - d.ms_descriptor;
        sequential_steps_.fetch_add(1);
        sink_->on_decision(d);
      },
      [this, &item](const KeyframeRecord& k, const Eigen::Isometry3d& T_map_sensor) { sink_->on_keyframe(k, T_map_sensor, item.map_cloud); });
  const double detector_ms = sw.ms();
  item.map_cloud.reset();
  if (out.correction) sink_->on_correction(*out.correction);
  sink_->on_keyframe_decided(item.input.key);
  retire_redundant(item, out);
  if (out.correction && out.correction->graph_solved) {  // after a solve
    release_free_heap();
    page_out_library_code(kCompilerLibraries);  // PoCL compiles a kernel variant now and then
  }
  std::lock_guard<std::mutex> s(stats_mutex_);
  stats_.profile.sequential_ms += detector_ms;
  stats_.profile.verify_ms += verify_ms;
  if (out.correction) stats_.profile.correction_ms += out.correction->ms;
  stats_.keyframes = static_cast<std::int64_t>(detector_.num_keyframes());
  stats_.loops_accepted = detector_.loops_accepted();
  stats_.loops_rejected = detector_.loops_rejected();
  stats_.steps_measured = detector_.steps_measured();
  stats_.steps_refused = detector_.steps_refused();
  stats_.steps_skewed = detector_.steps_skewed();
  stats_.bytes_per_keyframe = static_cast<std::int64_t>(detector_.bytes_per_keyframe());
  stats_.cached_feature_bytes = static_cast<std::int64_t>(detector_.cached_feature_bytes());
  T_map_odom_ = detector_.T_map_odom();
}

void LoopdEngine::retire_redundant(const ReadyKeyframe& item, const DetectorOutput& out) {
  const PlaceDensityConfig& policy = config_.retirement;
  if (!policy.enabled || !item.features) return;
  const bool looped =
      std::any_of(out.decisions.begin(), out.decisions.end(), [](const LoopDecision& d) { return d.status == LoopStatus::kAccepted; });
  if (!looped) return;  // only a loop ties the keyframe to the others at its place
  const KeyframeKey& key = item.input.key;
  const std::optional<PlaceKeyframe> newest = detector_.place_view(key);
  if (!newest) return;
  const double radius = policy.radius_per_spacing * selector_.spacing(item.features->scene_scale);
  std::vector<PlaceKeyframe> near = detector_.place_views_near(key, std::min(radius, config_.detector.gate.max_radius));
  for (PlaceKeyframe& k : near) k.retirable = k.key.session >= retirable_from_session_;
  std::vector<KeyframeKey> retired;
  for (const KeyframeKey& k : thin_place(*newest, near, radius, policy).retire)
    if (detector_.retire_keyframe(k)) retired.push_back(k);
  if (retired.empty()) return;
  sink_->on_keyframes_retired(key, retired);
  std::lock_guard<std::mutex> s(stats_mutex_);
  stats_.keyframes_retired += static_cast<std::int64_t>(retired.size());
}

void LoopdEngine::finish() {
  handle_associated(associator_.flush());
  {
    std::lock_guard<std::mutex> s(stats_mutex_);
    stats_.dropped_no_pose = associator_.dropped_no_pose();
    stats_.pending_scans = 0;
  }
  {
    std::unique_lock<std::mutex> lock(done_mutex_);
    while (!done_cv_.wait_for(lock, std::chrono::milliseconds(20), [&] { return sequenced_.load() >= next_sequence_; })) {}
  }
  // Every keyframe is sequenced and no worker calls the sink any more.
  if (auto c = detector_.final_correction()) {
    sink_->on_final_correction(*c);
    std::lock_guard<std::mutex> s(stats_mutex_);
    T_map_odom_ = detector_.T_map_odom();
  }
}

EngineStats LoopdEngine::stats() const {
  EngineStats s;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    s = stats_;
  }
  std::lock_guard<std::mutex> lock(queue_mutex_);
  s.queue_depth = static_cast<int>(queue_.size()) + busy_;
  return s;
}

EngineProgress LoopdEngine::progress() const {
  EngineProgress p;
  p.sequential.steps = sequential_steps_.load();
  p.sequential.pending = completed_.load() > sequenced_.load();
  p.workers.steps = worker_steps_.load();
  std::lock_guard<std::mutex> lock(queue_mutex_);
  p.workers.pending = !queue_.empty() || busy_ > 0;
  return p;
}

Eigen::Isometry3d LoopdEngine::T_map_odom() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return T_map_odom_;
}

}  // namespace loopd
