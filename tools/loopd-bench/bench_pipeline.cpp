// loopd-bench pipeline: the daemon's engine (association, keyframes, worker pool, detector, correction) on a recorded
// drive, without LCM transport: replay throughput (x real time), scan-to-event latency when a loop is verified, shed
// keyframes at a paced speed, and memory per stored keyframe.
// Targets (issue #8): replay >= 10x real time; at 1x no keyframe shed and latency p99 <= 200 ms; <= 150 KB per keyframe.
// --profile: where the replay's time went, stage by stage (issue 32).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <map>
#include <mutex>
#include <thread>

#include "lcm_log.hpp"
#include "loopd/runtime/loopd_engine.hpp"
#include "message_convert.hpp"
#include "scan_decode.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"
#include "loopd/base/stopwatch.hpp"

using namespace loopd;
using loopd::tools::fmt;

namespace {

double now_s() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

struct Input {
  bool is_scan = false, is_imu = false;
  std::int64_t utime = 0;
  PointCloud cloud;
  StampedPose pose;
  ImuSample imu;
};

/// Collects decisions and the latency from a scan's arrival to the decision about it.
class LatencySink : public EngineSink {
 public:
  void on_decision(const LoopDecision& d) override {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = arrival_.find(d.query_utime);
    if (d.stage != "descriptor" && it != arrival_.end() && !seen_.count(d.query_utime)) {
      latency_ms_.push_back((now_s() - it->second) * 1e3);
      seen_.insert({d.query_utime, true});
    }
    accepted_ += d.status == LoopStatus::kAccepted ? 1 : 0;
    ++decisions_;
  }
  void on_correction(const CorrectionOutput& c) override {
    std::lock_guard<std::mutex> lock(mutex_);
    correction_ms_.push_back(c.ms);
  }
  void arrived(std::int64_t utime) {
    std::lock_guard<std::mutex> lock(mutex_);
    arrival_[utime] = now_s();
  }
  std::vector<double> latency_ms_, correction_ms_;
  int accepted_ = 0, decisions_ = 0;

 private:
  std::mutex mutex_;
  std::map<std::int64_t, double> arrival_;
  std::map<std::int64_t, bool> seen_;
};

struct RunResult {
  double wall_s = 0.0, data_s = 0.0;
  EngineStats stats;
  tools::Summary latency, correction;
  double latency_p99 = 0.0;
  int accepted = 0, decisions = 0;
  std::int64_t peak_rss = 0;
};

RunResult run_once(const std::vector<Input>& inputs, const EngineConfig& base, double speed) {
  EngineConfig config = base;
  config.block_when_full = speed <= 0.0;              // as fast as possible = replay (never sheds); paced = live policy
  config.detector.parallel_candidates = speed > 0.0;  // as the daemon does live
  LatencySink sink;
  RunResult r;
  {
    LoopdEngine engine(config, &sink);
    const double t0 = now_s();
    const std::int64_t u0 = inputs.front().utime;
    tools::Progress progress(speed > 0 ? "paced run" : "replay", static_cast<std::int64_t>(inputs.size()));
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      const Input& in = inputs[i];
      if (speed > 0.0) {
        const double due = t0 + static_cast<double>(in.utime - u0) * 1e-6 / speed;
        const double wait = due - now_s();
        if (wait > 0) std::this_thread::sleep_for(std::chrono::duration<double>(wait));
      }
      if (in.is_scan) {
        sink.arrived(in.utime);
        engine.push_scan(in.utime, in.cloud, now_s());
      } else if (in.is_imu) {
        engine.push_imu(in.imu);
      } else {
        engine.push_pose(in.pose, now_s());
      }
      if (speed > 0.0) engine.tick(now_s());
      progress.update(static_cast<std::int64_t>(i + 1));
    }
    engine.finish();
    progress.finish();
    r.wall_s = now_s() - t0;
    r.data_s = static_cast<double>(inputs.back().utime - u0) * 1e-6;
    r.stats = engine.stats();
  }
  r.latency = tools::summarize(sink.latency_ms_);
  if (!sink.latency_ms_.empty()) {
    std::vector<double> v = sink.latency_ms_;
    std::sort(v.begin(), v.end());
    r.latency_p99 = v[std::min(v.size() - 1, static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(v.size()))) - 1)];
  }
  r.correction = tools::summarize(sink.correction_ms_);
  r.accepted = sink.accepted_;
  r.decisions = sink.decisions_;
  r.peak_rss = tools::peak_rss_bytes();
  return r;
}

/// The drive's scans and poses, decoded as loopd decodes them (decode_scan: wire bytes -> cloud), with the time that
/// took [ms]. False (the reason printed) when the drive cannot be read or holds fewer than 2 scans.
bool read_inputs(const std::string& drive, int max_scans, std::vector<Input>* inputs, int* scans, double* decode_ms) {
  LogReader reader;
  std::string error;
  if (!reader.open(drive, &error)) {
    std::cerr << "loopd-bench pipeline: " << error << "\n";
    return false;
  }
  LogEvent ev;
  while (reader.next(&ev)) {
    Input in;
    const Stopwatch sw;
    if (ev.channel == channels::kScan) {
      if (max_scans > 0 && *scans >= max_scans) break;
      DecodedScan m;
      if (!decode_scan(ev.data.data(), ev.data.size(), DecodeLimits{}, &m)) continue;
      in.is_scan = true;
      in.utime = m.utime;
      in.cloud = std::move(m.cloud);
      ++*scans;
    } else if (ev.channel == channels::kPose) {
      pose_t m;
      if (!LogReader::decode(ev, &m) || !from_message(m, &in.pose, &error)) continue;
      in.utime = m.utime;
    } else if (ev.channel == channels::kImu) {  // a gyro, read as loopd reads it (imu.enabled)
      imu_t m;
      if (!LogReader::decode(ev, &m) || !from_message(m, &in.imu, &error)) continue;
      in.is_imu = true;
      in.utime = m.utime;
    } else {
      continue;
    }
    *decode_ms += sw.ms();
    inputs->push_back(std::move(in));
  }
  if (*scans < 2) {
    std::cerr << "loopd-bench pipeline: " << drive << " holds fewer than 2 scans on " << channels::kScan << "\n";
    return false;
  }
  return true;
}

/// Where the replay's time went, by stage, per scan and per keyframe (EngineProfile; decoding measured while reading).
nlohmann::json print_profile(const RunResult& r, int scans, double decode_ms) {
  const EngineProfile& p = r.stats.profile;
  struct Row {
    const char* key;
    const char* name;
    const char* thread;
    double ms;
  };
  const std::vector<Row> rows = {{"decode", "decode (bounded, wire bytes -> cloud)", "LCM / ingest", decode_ms},
                                 {"ingest", "checks, association, keyframe rule, reference scans", "ingest", p.ingest_ms},
                                 {"sweep_motion", "sweep motion measured by the scans", "worker", p.sweep_motion_ms},
                                 {"deskew", "deskew (and the keyframe scan's copy)", "worker", p.deskew_ms},
                                 {"descriptors", "descriptors (M2DP, Scan Context)", "worker", p.descriptor_ms},
                                 {"prepare", "prepare (range image, segmentation, voxels, normals)", "worker", p.prepare_ms},
                                 {"map_cloud", "map cloud (reduce, encode)", "worker", p.map_cloud_ms},
                                 {"detector", "step, gate, ranking, bookkeeping", "sequential", p.sequential_ms - p.verify_ms - p.correction_ms},
                                 {"verification", "verification (4PCS, GICP, Hungarian)", "sequential", p.verify_ms},
                                 {"correction", "correction (heuristic, pose graph)", "sequential", p.correction_ms}};
  const double keyframes = static_cast<double>(std::max<std::int64_t>(1, p.keyframes_prepared));
  tools::Table t({"stage", "thread", "total [s]", "ms per scan", "ms per keyframe", "% of one core at 1x"});
  nlohmann::json j = nlohmann::json::object();
  double total = 0.0;
  auto add = [&](const std::string& name, const std::string& thread, double ms) {
    t.add({name, thread, fmt(ms * 1e-3, 2), fmt(ms / scans, 2), fmt(ms / keyframes, 2), fmt(100.0 * ms * 1e-3 / r.data_s, 1)});
  };
  for (const Row& row : rows) {
    add(row.name, row.thread, row.ms);
    j[row.key] = row.ms;
    total += row.ms;
  }
  add("total", "", total);
  std::cout << "where the replay's time went (" << scans << " scans, " << p.keyframes_prepared << " keyframes prepared, " << fmt(r.data_s, 1)
            << " s of data):\n"
            << t.str();
  return j;
}

}  // namespace

int run_bench_pipeline(int argc, char** argv) {
  CLI::App app("loopd-bench pipeline: the engine on a recorded drive (replay speed, latency, shedding, memory)", "loopd-bench pipeline");
  std::string drive, sensor = "hdl64";
  int threads = 0, max_scans = 0;
  double paced_speed = 1.0;
  bool json = false, skip_paced = false, profile = false;
  app.add_option("--drive", drive, "lcm-logger file with LIDAR_SCAN and ODOMETRY_POSE (e.g. from loopd-sim)")->required();
  app.add_option("--sensor", sensor, "lidar model preset")->capture_default_str();
  app.add_option("--threads", threads, "worker threads (0 = hardware threads)")->capture_default_str();
  app.add_option("--max-scans", max_scans, "use only the first N scans (0 = all)")->capture_default_str();
  app.add_option("--paced-speed", paced_speed, "speed of the paced (live-policy) run; 1 = real time")->capture_default_str();
  app.add_flag("--no-paced", skip_paced, "only the replay run");
  app.add_flag("--profile", profile, "also print where the replay's time went, stage by stage (ms per scan and per keyframe)");
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;

  std::vector<Input> inputs;
  int scans = 0;
  double decode_ms = 0.0;
  if (!read_inputs(drive, max_scans, &inputs, &scans, &decode_ms)) return 1;

  EngineConfig config;
  config.detector.sensor = sensor;
  config.num_threads = threads;
  if (auto e = config.validate()) {
    std::cerr << "loopd-bench pipeline: " << *e << "\n";
    return 1;
  }
  const RunResult replay = run_once(inputs, config, 0.0);
  RunResult paced;
  if (!skip_paced) paced = run_once(inputs, config, paced_speed);

  tools::Table t({"figure", "replay (as fast as possible)", skip_paced ? "" : "paced at " + fmt(paced_speed, 1) + "x (live policy)"});
  auto row = [&](const std::string& name, const std::string& a, const std::string& b) { t.add({name, a, skip_paced ? "" : b}); };
  row("scans / keyframes", std::to_string(scans) + " / " + std::to_string(replay.stats.keyframes),
      std::to_string(scans) + " / " + std::to_string(paced.stats.keyframes));
  row("data / wall [s]", fmt(replay.data_s, 1) + " / " + fmt(replay.wall_s, 1), fmt(paced.data_s, 1) + " / " + fmt(paced.wall_s, 1));
  row("x real time", fmt(replay.data_s / replay.wall_s, 2), fmt(paced.data_s / std::max(1e-9, paced.wall_s), 2));
  row("loops accepted / decisions", std::to_string(replay.accepted) + " / " + std::to_string(replay.decisions),
      std::to_string(paced.accepted) + " / " + std::to_string(paced.decisions));
  row("keyframes shed", std::to_string(replay.stats.shed), std::to_string(paced.stats.shed));
  auto lat = [](const RunResult& r) {
    return fmt(r.latency.median, 0) + " / " + fmt(r.latency.p95, 0) + " / " + fmt(r.latency_p99, 0) + " / " + fmt(r.latency.max, 0);
  };
  row("latency verified [ms] median/p95/p99/max", lat(replay), lat(paced));
  row("correction [ms] median/max", fmt(replay.correction.median, 1) + " / " + fmt(replay.correction.max, 1),
      fmt(paced.correction.median, 1) + " / " + fmt(paced.correction.max, 1));
  row("bytes per keyframe", std::to_string(replay.stats.bytes_per_keyframe), std::to_string(paced.stats.bytes_per_keyframe));
  row("peak RSS [MB]", fmt(static_cast<double>(replay.peak_rss) / 1e6, 0), fmt(static_cast<double>(paced.peak_rss) / 1e6, 0));
  row("descriptor device", replay.stats.device, paced.stats.device);
  std::cout << t.str();
  const nlohmann::json profile_ms = profile ? print_profile(replay, scans, decode_ms) : nlohmann::json();
  if (json) {
    // p99 with the sample sizes here (tens to hundreds of verified keyframes) is the max or next to it.
    nlohmann::json j{{"scans", scans},
                     {"keyframes", replay.stats.keyframes},
                     {"replay_x_real_time", replay.data_s / replay.wall_s},
                     {"replay_wall_s", replay.wall_s},
                     {"loops_accepted", replay.accepted},
                     {"bytes_per_keyframe", replay.stats.bytes_per_keyframe},
                     {"peak_rss_bytes", replay.peak_rss},
                     {"device", replay.stats.device}};
    if (profile) j["profile_ms"] = profile_ms;
    if (!skip_paced) {
      j["paced_speed"] = paced_speed;
      j["paced_shed"] = paced.stats.shed;
      j["paced_loops_accepted"] = paced.accepted;
      j["paced_latency_median_ms"] = paced.latency.median;
      j["paced_latency_p95_ms"] = paced.latency.p95;
      j["paced_latency_p99_ms"] = paced.latency_p99;
      j["paced_latency_max_ms"] = paced.latency.max;
    }
    tools::print_json_line(j);
  }
  return 0;
}
