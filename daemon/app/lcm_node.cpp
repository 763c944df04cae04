#include "lcm_node.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <chrono>
#include <cstring>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <fstream>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <optional>
#include <thread>
#include <variant>

#include <pthread.h>

#include "bounded_decode.hpp"
#include "loopd/runtime/log_level.hpp"
#include "lcm_log.hpp"
#include "message_convert.hpp"
#include "loopd/runtime/node_runtime.hpp"
#include "loopd/runtime/view_sink.hpp"
#include "output_messages.hpp"
#include "status_endpoints.hpp"
#include "scan_decode.hpp"
#include "systemd_notify.hpp"
#include "trajectory_publisher.hpp"
#include "watchdog.hpp"

namespace loopd {
namespace {

double wall_s() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
std::int64_t wall_utime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

/// Logs an anomaly on its 1st, (N+1)th, ... occurrence.
void log_anomaly(const std::string& what, std::int64_t count, int every) {
  if (!log_enabled(LogLevel::kWarn)) return;
  if (every <= 0 || (count - 1) % every == 0) std::cerr << "loopd: " << what << " (" << count << " so far)" << std::endl;
}

/// Publishes results on LCM and/or into a log file.
class OutputSink : public EngineSink {
 public:
  OutputSink(const NodeConfig& node, lcm::LCM* lcm, LogWriter* log, bool data_time) : node_(node), lcm_(lcm), log_(log), data_time_(data_time) {}

  void on_keyframe(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_sensor, const MapCloudBlob&) override {
    if (node_.localize) localization_.on_keyframe(keyframe, T_map_sensor);
  }
  void on_keyframe_decided(const KeyframeKey& keyframe) override {
    if (!node_.localize) return;
    if (const std::optional<LocalizationState> s = localization_.on_keyframe_decided(keyframe))
      publish(node_.localization_channel, data_time_ ? s->utime : wall_utime(), to_message(*s));
  }
  void on_decision(const LoopDecision& d) override {
    if (node_.localize) localization_.on_decision(d);
    const std::int64_t t = data_time_ ? d.query_utime : wall_utime();
    publish(node_.loop_event_channel, t, to_message(d, t));
    if (!node_.quiet && d.status == LoopStatus::kAccepted && log_enabled(LogLevel::kInfo))
      std::fprintf(stderr, "loopd: loop accepted: keyframe %lld -> %lld (descriptor %.3f, lcp %.2f, icp %.3f m, %.0f ms)\n",
                   static_cast<long long>(d.query.index), static_cast<long long>(d.match.index), d.descriptor_distance, d.lcp_fraction,
                   d.icp_residual, d.ms_total);
    last_data_utime_ = d.query_utime;
  }
  void on_correction(const CorrectionOutput& c) override {
    if (node_.localize) localization_.on_correction(c);
    const std::int64_t t = data_time_ ? last_data_utime_.load() : wall_utime();
    publish(node_.trajectory_channel, t, trajectory_.make_message(c, t));
  }
  void on_final_correction(const CorrectionOutput& c) override {
    const std::int64_t t = data_time_ ? last_data_utime_.load() : wall_utime();
    publish(node_.trajectory_channel, t, trajectory_.final_message(c, t));
  }
  /// Every keyframe of the last correction, when the last trajectory_t was partial (end of a run).
  void finish_trajectory() {
    const std::int64_t t = data_time_ ? last_data_utime_.load() : wall_utime();
    if (auto m = trajectory_.final_snapshot(t)) publish(node_.trajectory_channel, t, *m);
  }
  template <typename Msg>
  void publish(const std::string& channel, std::int64_t t, const Msg& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (lcm_) lcm_->publish(channel, &msg);
    if (log_) {
      log_->write_message(channel, t, msg);
      log_->flush();  // "published" means in the file: a kill must not take buffered events with it
      ++written_;
    }
  }
  std::int64_t written() const { return written_; }

 private:
  const NodeConfig& node_;
  lcm::LCM* lcm_;
  LogWriter* log_;
  bool data_time_;
  TrajectoryPublisher trajectory_{node_.trajectory_output};
  LocalizationTracker localization_;  ///< --localize: where this run lies in the map, published per keyframe
  std::mutex mutex_;
  std::int64_t written_ = 0;
  std::atomic<std::int64_t> last_data_utime_{0};  ///< the fleet thread publishes joint corrections at it
};

/// Decoded input waiting for the ingest thread, with the time it arrived (wall clock live, logger time in replay).
struct Input {
  std::variant<DecodedScan, pose_t, imu_t> msg;
  double arrival_s = 0.0;
};

/// Subscribes to the scan, pose and IMU channels; decodes with decode_bounded (every byte is hostile: LCM is
/// unauthenticated multicast) and counts; hands messages to `deliver`. Nothing thrown escapes into LCM.
class InputHandler {
 public:
  InputHandler(const NodeConfig& node, const DecodeLimits& limits) : node_(node), limits_(limits) {
    scan_.channel = node.scan_channel;
    pose_.channel = node.pose_channel;
    imu_.channel = node.imu_channel;
  }
  std::function<bool(Input&&)> deliver;  // returns false when the input had to be dropped

  void on_raw(const lcm::ReceiveBuffer* rbuf, const std::string& channel) { on_bytes(rbuf->data, rbuf->data_size, channel, wall_s()); }

  void on_bytes(const void* data, std::size_t size, const std::string& channel, double arrival_s) noexcept {
    try {
      handle(data, size, channel, arrival_s);
    } catch (const std::exception& e) {  // bad_alloc on a scan within the caps but beyond free memory, ...
      count_malformed(channel, std::string("could not handle a message: ") + e.what());
    } catch (...) {
      count_malformed(channel, "could not handle a message");
    }
  }

  ChannelCounters scan_, pose_, imu_;
  std::mutex counters_mutex_;  ///< guards scan_, pose_ and imu_ (LCM thread, ingest thread, status)
  /// The counters of a subscribed channel (counters_mutex_ held).
  ChannelCounters& counters_of(const std::string& channel) {
    return channel == node_.scan_channel ? scan_ : channel == node_.imu_channel ? imu_ : pose_;
  }

 private:
  void handle(const void* data, std::size_t size, const std::string& channel, double arrival_s) {
    const bool is_scan = channel == node_.scan_channel;
    {
      std::lock_guard<std::mutex> lock(counters_mutex_);
      ++counters_of(channel).received;
    }
    Input in;
    in.arrival_s = arrival_s;
    DecodeResult r;
    if (is_scan) {
      DecodedScan m;
      r = decode_scan(data, size, limits_, &m);  // older publishers' layout too; contents checked
      if (r.ok) in.msg = std::move(m);
    } else if (channel == node_.imu_channel) {
      imu_t m;
      r = decode_bounded(data, size, limits_, &m);
      if (r.ok) in.msg = m;
    } else {
      pose_t m;
      r = decode_bounded(data, size, limits_, &m);
      if (r.ok) in.msg = m;
    }
    if (!r.ok) {
      count_malformed(channel, "could not decode a " + std::to_string(size) + "-byte message: " + r.reason + " at byte " + std::to_string(r.offset));
      return;
    }
    if (deliver && !deliver(std::move(in))) {
      std::int64_t dropped = 0;
      {
        std::lock_guard<std::mutex> lock(counters_mutex_);
        dropped = ++counters_of(channel).dropped;
      }
      log_anomaly("input queue full, dropped a message on " + channel, dropped, node_.log_every_n);
    }
  }
  void count_malformed(const std::string& channel, const std::string& what) {
    std::int64_t malformed = 0;
    {
      std::lock_guard<std::mutex> lock(counters_mutex_);
      malformed = ++counters_of(channel).malformed;
    }
    log_anomaly(what + " on " + channel, malformed, node_.log_every_n);
  }

  const NodeConfig& node_;
  DecodeLimits limits_;
};

/// One pushed message's outcome, counted on its channel: accepted, or rejected by the engine and logged with what
/// `rejected()` returns (the line and the engine's count so far; built only for a rejection, not per message).
template <typename Rejected>
void count_pushed(InputHandler& h, ChannelCounters& counters, bool accepted, int every, const Rejected& rejected) {
  if (!accepted) {
    const auto [why, count] = rejected();
    log_anomaly(why, count, every);
    return;
  }
  std::lock_guard<std::mutex> lock(h.counters_mutex_);
  ++counters.accepted;
}

/// A message that decoded but does not convert (non-finite numbers, out of range): counted as malformed and logged.
void count_unconvertible(InputHandler& h, ChannelCounters& counters, const std::string& why, int every) {
  std::int64_t n = 0;
  {
    std::lock_guard<std::mutex> lock(h.counters_mutex_);
    n = ++counters.malformed;
  }
  log_anomaly(why, n, every);
}

/// Converts one decoded input and feeds the engine; counts conversion failures as malformed.
void ingest(LoopdEngine& engine, InputHandler& h, Input& in, const NodeConfig& node, std::int64_t* last_data_utime) {
  std::string error;
  const int every = node.log_every_n;
  if (auto* scan = std::get_if<DecodedScan>(&in.msg)) {
    *last_data_utime = std::max(*last_data_utime, scan->utime);
    const bool ok = engine.push_scan(scan->utime, std::move(scan->cloud), in.arrival_s);
    count_pushed(h, h.scan_, ok, every, [&] {
      return std::make_pair(
          "rejected a scan at utime " + std::to_string(scan->utime) + ": empty, all non-finite, too large, or duplicate/out-of-order utime",
          engine.stats().invalid_scans);
    });
  } else if (auto* pose = std::get_if<pose_t>(&in.msg)) {
    StampedPose p;
    if (!from_message(*pose, &p, &error)) return count_unconvertible(h, h.pose_, "rejected a pose on " + node.pose_channel + ": " + error, every);
    *last_data_utime = std::max(*last_data_utime, pose->utime);
    const bool ok = engine.push_pose(p, in.arrival_s);
    count_pushed(h, h.pose_, ok, every, [&] {
      return std::make_pair("rejected a pose with a duplicate or out-of-order utime " + std::to_string(pose->utime), engine.stats().invalid_poses);
    });
  } else if (auto* imu = std::get_if<imu_t>(&in.msg)) {
    ImuSample sample;
    if (!from_message(*imu, &sample, &error))
      return count_unconvertible(h, h.imu_, "rejected a gyro sample on " + node.imu_channel + ": " + error, every);
    const bool ok = engine.push_imu(sample);
    count_pushed(h, h.imu_, ok, every, [&] {
      return std::make_pair("rejected a gyro sample with a duplicate or out-of-order utime " + std::to_string(imu->utime),
                            engine.stats().invalid_imu);
    });
  }
}

/// Says once per kind what the input-health counters show: scan loss past 1 %, clock jumps, odometry resets,
/// sensor changes (each logged on its 1st, (N+1)th, ... occurrence like other anomalies).
class InputHealthLog {
 public:
  void update(const EngineStats& s, int every) {
    if (!loss_warned_ && s.scan_loss_fraction > 0.01 && s.scans_in + s.scans_lost_estimate >= 100 && log_enabled(LogLevel::kWarn)) {
      loss_warned_ = true;
      std::fprintf(stderr,
                   "loopd: warning: about %lld scans (%.1f %%) never arrived (gaps in the scan rate). LCM drops a whole message when one UDP "
                   "fragment is lost: enlarge the receive buffer (see the warning at start) or check the network.\n",
                   static_cast<long long>(s.scans_lost_estimate), 100.0 * s.scan_loss_fraction);
    }
    report("the data clock jumped; following the new time line", s.clock_jumps, &clock_jumps_, every);
    report("odometry reset (a jump the vehicle cannot have made); a new session opens (sessions.on_odometry_reset)", s.odometry_resets,
           &odometry_resets_, every);
    report("the sensor layout changed (points per scan or rings)", s.sensor_changes, &sensor_changes_, every);
  }

 private:
  static void report(const char* what, std::int64_t now, std::int64_t* seen, int every) {
    while (*seen < now) log_anomaly(what, ++*seen, every);
  }
  bool loss_warned_ = false;
  std::int64_t clock_jumps_ = 0, odometry_resets_ = 0, sensor_changes_ = 0;
};

DecodeLimits decode_limits(const EngineConfig& e) {
  DecodeLimits limits;
  limits.max_points = e.max_points_per_scan;
  return limits;
}

std::vector<ChannelCounters> counters(InputHandler& h, const EngineStats& s) {
  std::lock_guard<std::mutex> lock(h.counters_mutex_);
  ChannelCounters scan = h.scan_;
  scan.dropped += s.dropped_no_pose + s.shed;
  if (h.imu_.received == 0) return {scan, h.pose_};
  return {scan, h.pose_, h.imu_};
}

void fill_summary(RunSummary* summary, LoopdEngine& engine, InputHandler& h) {
  if (!summary) return;
  summary->engine = engine.stats();
  std::lock_guard<std::mutex> lock(h.counters_mutex_);
  summary->scans_received = h.scan_.received;
  summary->poses_received = h.pose_.received;
  summary->malformed = h.scan_.malformed + h.pose_.malformed + h.imu_.malformed;
  summary->dropped_input = h.scan_.dropped + h.pose_.dropped + h.imu_.dropped;
}

/// The service manager's view of a live run (sd_notify): READY=1 once listening, a STATUS= line every status period,
/// WATCHDOG=1 while the pipeline makes progress, STOPPING=1 at the stop. Polled from the loop that handles LCM, so a
/// stuck LCM loop stops the pings too. Without NOTIFY_SOCKET only the stall log lines remain.
class ServiceLink {
 public:
  ServiceLink(const NodeConfig& node, NodeRuntime& runtime, const std::atomic<std::int64_t>& ingest_steps, StatusEndpoints& endpoints)
      : node_(node),
        runtime_(runtime),
        engine_(runtime.engine()),
        ingest_steps_(ingest_steps),
        endpoints_(endpoints),
        watchdog_(notifier_, node.watchdog_stall) {
    if (notifier_.watchdog_usec() > 0 && log_enabled(LogLevel::kInfo))
      std::fprintf(stderr, "loopd: systemd watchdog: a ping every %.1f s while the pipeline makes progress (stall limit %.1f s)\n",
                   notifier_.ping_interval_s(), node.watchdog_stall);
  }
  void ready() {
    notifier_.ready(status_line());
    next_status_s_ = wall_s() + node_.status_period;
  }
  void poll() {
    const double now = wall_s();
    const EngineProgress p = engine_.progress();
    const bool engine_pending = p.workers.pending || p.sequential.pending;
    // The ingest thread loops at least every 100 ms; it may wait on the engine's backpressure, which the engine's
    // stages answer for, so it is only judged while the engine has nothing pending.
    endpoints_.set_alive(watchdog_.poll(
        {{"sequential stage", p.sequential}, {"worker pool", p.workers}, {"ingest thread", {ingest_steps_.load(), !engine_pending}}}, now));
    if (now < next_status_s_) return;
    next_status_s_ = now + node_.status_period;
    notifier_.status(status_line());
  }
  void stopping() { notifier_.stopping("stopping: " + status_line()); }

 private:
  std::string status_line() const {
    const EngineStats s = engine_.stats();
    const MapStatus m = runtime_.map_status(s);
    std::string map = m.path.empty() ? "map in memory" : "map " + m.path + " " + std::to_string(m.bytes / 1048576) + " MB";
    if (m.write_failures > 0) map += ", " + std::to_string(m.write_failures) + " refused writes";
    return "keyframes " + std::to_string(s.keyframes) + ", loops accepted " + std::to_string(s.loops_accepted) + ", rejected " +
           std::to_string(s.loops_rejected) + ", queue " + std::to_string(s.queue_depth) + ", shed " + std::to_string(s.shed) + "; " + map;
  }

  const NodeConfig& node_;
  NodeRuntime& runtime_;
  LoopdEngine& engine_;
  const std::atomic<std::int64_t>& ingest_steps_;
  StatusEndpoints& endpoints_;
  SystemdNotifier notifier_;
  PipelineWatchdog watchdog_;
  double next_status_s_ = 0.0;
};

/// --http: the page's title, and with a map its outline (stored keyframes, correction, decisions, newest clouds).
void show_map(NodeRuntime& runtime, ViewFeed& feed, const std::string& source) {
  feed.set_source(source);
  MapStore* map = runtime.map_before_start();
  if (!map) return;
  const StoreStatus status = load_map_view(*map, feed, MapViewOptions{});
  if (!status.ok() && log_enabled(LogLevel::kWarn)) std::fprintf(stderr, "loopd: http: the map's outline is not shown: %s\n", status.message.c_str());
}

/// Handles LCM until `stop`, polling the service link at least every 100 ms. False after an LCM error.
bool handle_lcm_until_stopped(lcm::LCM& lcm, const std::atomic<bool>& stop, ServiceLink& service) {
  while (!stop.load()) {
    if (lcm.handleTimeout(100) < 0) {
      if (stop.load() || errno == EINTR) continue;  // a signal interrupted the wait
      std::cerr << "loopd: LCM error while handling messages: " << std::strerror(errno) << std::endl;
      return false;
    }
    service.poll();
  }
  return true;
}

}  // namespace

bool check_receive_buffer(const std::string& lcm_url, std::int64_t points) {
  if (lcm_url.rfind("udpm://", 0) != 0) return false;
  const std::int64_t needed = points * 18 + 4096;  // x, y, z, intensity (float32) + ring (int16) per point
  std::int64_t buffer = 0;
  const auto pos = lcm_url.find("recv_buf_size=");
  if (pos != std::string::npos) {
    buffer = std::atoll(lcm_url.c_str() + pos + 14);
  } else {
    std::ifstream in("/proc/sys/net/core/rmem_default");
    in >> buffer;
  }
  std::int64_t rmem_max = 0;
  std::ifstream("/proc/sys/net/core/rmem_max") >> rmem_max;
  const std::int64_t effective = (pos != std::string::npos && rmem_max > 0) ? std::min(buffer, rmem_max) : buffer;
  if (effective >= 2 * needed) return false;
  if (!log_enabled(LogLevel::kWarn)) return true;
  std::fprintf(stderr,
               "loopd: warning: UDP receive buffer is %lld KiB but one %lld-point scan is about %lld KiB; LCM drops a whole message when one "
               "fragment is lost. Fix: add recv_buf_size=%lld to the LCM URL and allow it with 'sysctl -w net.core.rmem_max=%lld'.\n",
               static_cast<long long>(effective / 1024), static_cast<long long>(points), static_cast<long long>(needed / 1024),
               static_cast<long long>(8 * needed), static_cast<long long>(8 * needed));
  return true;
}

int run_live(const NodeConfig& node, const EngineConfig& engine_config, const std::atomic<bool>& stop, RunSummary* summary) {
  lcm::LCM lcm(node.lcm_url);
  if (!lcm.good()) {
    std::cerr << "loopd: cannot initialise LCM with URL '" << node.lcm_url << "'" << std::endl;
    return 3;
  }
  // Expected scan size from the lidar model (HDL-64E: 64 x 2083 rays, about 2.4 MB on the wire).
  const auto model =
      sensor_model_from_choice(engine_config.detector.sensor, engine_config.detector.sensor_elevations_deg, engine_config.detector.sensor_columns);
  check_receive_buffer(node.lcm_url, model ? model->rays_per_scan() : 130000);
  const double start = wall_s();
  StatusEndpoints endpoints(node);  // --http: served from before the map opens until after it closes
  std::unique_ptr<HttpServer> http;
  if (!serve_status(node.http_listen, endpoints, &http)) return 2;
  OutputSink sink(node, &lcm, nullptr, false);  // before the runtime: its engine and writer deliver to it until they go
  ViewSink view(sink, endpoints.feed());        // --http: the live page sees what is published
  NodeRuntime runtime(node);
  if (!runtime.open_map()) return 2;
  if (http) show_map(runtime, endpoints.feed(), "live " + node.lcm_url);
  EngineConfig live_config = engine_config;
  live_config.detector.parallel_candidates = true;  // spare cores shorten the latency tail; same decisions
  if (!runtime.start(live_config, http ? static_cast<EngineSink&>(view) : sink, "live " + node.lcm_url, false)) return 2;
  LoopdEngine& engine = runtime.engine();
  InputHandler handler(node, decode_limits(engine_config));
  InputHealthLog health_log;
  endpoints.update(make_status(wall_utime(), wall_s() - start, engine.stats(), counters(handler, engine.stats()), resident_memory_bytes(),
                               runtime.map_status(engine.stats())));

  std::mutex qm;
  std::condition_variable qcv;
  std::deque<Input> queue;
  bool done = false;
  handler.deliver = [&](Input&& in) {
    std::lock_guard<std::mutex> lock(qm);
    if (static_cast<int>(queue.size()) >= node.input_queue_capacity) return false;
    queue.push_back(std::move(in));
    qcv.notify_one();
    return true;
  };
  lcm.subscribe(node.scan_channel, &InputHandler::on_raw, &handler);
  lcm.subscribe(node.pose_channel, &InputHandler::on_raw, &handler);
  if (engine_config.imu.enabled) lcm.subscribe(node.imu_channel, &InputHandler::on_raw, &handler);

  std::atomic<std::int64_t> ingest_steps{0};  // the ingest thread's loops, for the watchdog
  std::thread ingest_thread([&] {
    pthread_setname_np(pthread_self(), "loopd-ingest");
    std::int64_t last_data_utime = 0;
    double next_status = wall_s() + node.status_period;
    for (;; ingest_steps.fetch_add(1)) {
      std::deque<Input> batch;
      {
        std::unique_lock<std::mutex> lock(qm);
        qcv.wait_for(lock, std::chrono::milliseconds(100), [&] { return done || !queue.empty(); });
        if (done) break;
        batch.swap(queue);
      }
      for (auto& in : batch) {
        try {
          ingest(engine, handler, in, node, &last_data_utime);
        } catch (const std::exception& e) {  // e.g. bad_alloc converting a large scan: skip it, keep running
          std::lock_guard<std::mutex> lock(handler.counters_mutex_);
          log_anomaly(std::string("could not process an input message: ") + e.what(), ++handler.scan_.malformed, node.log_every_n);
        }
      }
      const double now = wall_s();
      engine.tick(now);
      if (now >= next_status) {
        next_status = now + node.status_period;
        const EngineStats s = engine.stats();
        health_log.update(s, node.log_every_n);
        const status_t status = make_status(wall_utime(), now - start, s, counters(handler, s), resident_memory_bytes(), runtime.map_status(s));
        endpoints.update(status);
        sink.publish(node.status_channel, wall_utime(), status);
      }
    }
  });

  if (log_enabled(LogLevel::kInfo))
    std::cerr << "loopd: listening on " << node.scan_channel << ", " << node.pose_channel
              << (engine_config.imu.enabled ? " and " + node.imu_channel : std::string()) << " (" << node.lcm_url
              << "), descriptor device: " << engine.stats().device << std::endl;
  ServiceLink service(node, runtime, ingest_steps, endpoints);
  service.ready();  // the map is open and resumed, both channels subscribed
  const bool lcm_ok = handle_lcm_until_stopped(lcm, stop, service);
  service.stopping();  // before the engine drains and the map closes
  {
    std::lock_guard<std::mutex> lock(qm);
    done = true;
  }
  qcv.notify_all();
  ingest_thread.join();
  runtime.finish();
  fill_summary(summary, engine, handler);
  if (summary) summary->seconds = wall_s() - start;
  log_page_stats(endpoints, wall_s() - start);
  return lcm_ok ? 0 : 3;
}

int run_replay(const NodeConfig& node, const EngineConfig& engine_config, const std::string& input_log, const std::string& output_log,
               const std::string& publish_url, const std::atomic<bool>& stop, RunSummary* summary) {
  // loopd's own reader, not LCM's file provider: a damaged event header is skipped and counted instead of ending
  // the replay, and no length in the file is trusted before it is checked against the file.
  LogReader reader;
  std::string error;
  if (!reader.open(input_log, &error)) {
    std::cerr << "loopd: " << error << std::endl;
    return 2;
  }
  StatusEndpoints endpoints(node);  // --http on a replay: the figures of its newest status (data time)
  std::unique_ptr<HttpServer> http;
  if (!serve_status(node.http_listen, endpoints, &http)) return 2;
  LogWriter writer;
  std::unique_ptr<lcm::LCM> publisher;
  std::optional<OutputSink> sink;  // before the runtime: its engine and writer deliver to it until they go
  std::optional<ViewSink> view;
  NodeRuntime runtime(node);
  if (!runtime.open_map()) return 2;
  if (http) show_map(runtime, endpoints.feed(), "replay " + input_log);
  // A replay resumed on its map adds the rest of the events to the output of the run that stopped.
  if (!output_log.empty() && !writer.open(output_log, &error, runtime.map_holds_keyframes())) {
    std::cerr << "loopd: " << error << std::endl;
    return 2;
  }
  if (!publish_url.empty()) {
    publisher = std::make_unique<lcm::LCM>(publish_url);
    if (!publisher->good()) {
      std::cerr << "loopd: cannot initialise LCM with URL '" << publish_url << "'" << std::endl;
      return 3;
    }
  }
  const double start = wall_s();
  EngineConfig config = engine_config;
  config.block_when_full = true;  // replay never sheds: it waits for the workers
  sink.emplace(node, publisher.get(), output_log.empty() ? nullptr : &writer, true);
  if (http) view.emplace(*sink, endpoints.feed());
  if (!runtime.start(config, view ? static_cast<EngineSink&>(*view) : *sink, "replay " + input_log, true)) return 2;
  LoopdEngine& engine = runtime.engine();
  InputHandler handler(node, decode_limits(engine_config));
  InputHealthLog health_log;
  std::int64_t last_data_utime = 0, first_data_utime = 0, next_status_utime = 0;
  handler.deliver = [&](Input&& in) {
    ingest(engine, handler, in, node, &last_data_utime);
    if (first_data_utime == 0) first_data_utime = last_data_utime;
    if (last_data_utime >= next_status_utime) {
      // Status at the configured period of data time, so the output log is the same on every replay.
      next_status_utime = last_data_utime + static_cast<std::int64_t>(node.status_period * 1e6);
      EngineStats s = engine.stats();
      health_log.update(s, node.log_every_n);
      const status_t status = make_status(last_data_utime, static_cast<double>(last_data_utime - first_data_utime) * 1e-6, s, counters(handler, s),
                                          resident_memory_bytes(), runtime.map_status(s));
      endpoints.update(status);
      sink->publish(node.status_channel, last_data_utime, status);
    }
    return true;
  };
  LogEvent event;
  while (!stop.load() && reader.next(&event)) {
    if (event.channel != node.scan_channel && event.channel != node.pose_channel && (!engine_config.imu.enabled || event.channel != node.imu_channel))
      continue;
    // The logger's receive time is the arrival clock that data time is checked against (clock jumps).
    handler.on_bytes(event.data.data(), event.data.size(), event.channel, static_cast<double>(event.timestamp) * 1e-6);
  }
  if (!reader.problems().empty()) std::cerr << "loopd: " << reader.problems() << " (the rest of the log was read)" << std::endl;
  runtime.finish();
  sink->finish_trajectory();
  const EngineStats s = engine.stats();
  health_log.update(s, node.log_every_n);
  sink->publish(node.status_channel, last_data_utime,
                make_status(last_data_utime, static_cast<double>(last_data_utime - first_data_utime) * 1e-6, s, counters(handler, s),
                            resident_memory_bytes(), runtime.map_status(s)));
  fill_summary(summary, engine, handler);
  if (summary) {
    summary->seconds = wall_s() - start;
    summary->data_seconds = static_cast<double>(last_data_utime - first_data_utime) * 1e-6;
    summary->events_written = sink->written();
    summary->log_corrupt_headers = reader.stats().corrupt_headers;
  }
  writer.close();
  log_page_stats(endpoints, wall_s() - start);
  return 0;
}

}  // namespace loopd
