#include "eval_log.hpp"

#include <algorithm>
#include <filesystem>
#include <loopd/loop_event_t.hpp>

#include "loop_event_convert.hpp"
#include <unordered_map>
#include <loopd/point_cloud_t.hpp>
#include <loopd/pose_t.hpp>
#include <loopd/trajectory_t.hpp>

#include "lcm_log.hpp"
#include "message_convert.hpp"
#include "trajectory_assembly.hpp"

namespace loopd::tools {
namespace {

std::int64_t file_bytes(const std::string& path) {
  std::error_code ec;
  const auto n = std::filesystem::file_size(path, ec);
  return ec ? 0 : static_cast<std::int64_t>(n);
}

std::int64_t read_be64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return static_cast<std::int64_t>(v);
}

/// The utime of an encoded point_cloud_t (either layout: both start with fingerprint and int64 utime) without decoding
/// its arrays.
bool scan_utime(const LogEvent& ev, std::int64_t* utime) {
  if (ev.data.size() < 16) return false;
  const std::int64_t hash = read_be64(ev.data.data());
  if (hash != point_cloud_t::getHash() && hash != kPointCloudV1Hash) return false;
  *utime = read_be64(ev.data.data() + 8);
  return true;
}

}  // namespace

bool read_drive_log(const std::string& path, const EvalChannels& ch, EvalInput* input, LogReadStats* stats, const ProgressFn& progress,
                    std::string* error) {
  LogReader reader;
  if (!reader.open(path, error)) return false;
  const std::int64_t total = file_bytes(path);
  std::int64_t done = 0;
  LogEvent ev;
  pose_t pose_msg;
  while (reader.next(&ev)) {
    ++stats->events;
    done += LogReader::kEventHeaderBytes + static_cast<std::int64_t>(ev.channel.size() + ev.data.size());
    if (progress && (stats->events % 64) == 0) progress(done, total);
    if (ev.channel == ch.scan) {
      std::int64_t u = 0;
      if (!scan_utime(ev, &u)) {
        ++stats->malformed;
        continue;
      }
      input->scan_utimes.push_back(u);
      ++stats->scans;
    } else if (ev.channel == ch.ground_truth || ev.channel == ch.odometry) {
      StampedPose p;
      std::string why;
      if (!LogReader::decode(ev, &pose_msg) || !from_message(pose_msg, &p, &why)) {
        ++stats->malformed;
        continue;
      }
      if (ev.channel == ch.ground_truth) {
        input->ground_truth.push_back(p);
        ++stats->ground_truth;
      } else {
        input->odometry.push_back(p);
        ++stats->odometry;
      }
    } else {
      ++stats->skipped;
    }
  }
  if (progress) progress(total, total);
  if (stats->ground_truth == 0) {
    if (error) *error = "drive log " + path + " has no '" + ch.ground_truth + "' poses";
    return false;
  }
  if (stats->odometry == 0) {
    if (error) *error = "drive log " + path + " has no '" + ch.odometry + "' poses";
    return false;
  }
  return true;
}

bool read_results_log(const std::string& path, const EvalChannels& ch, EvalInput* input, LogReadStats* stats, const ProgressFn& progress,
                      std::string* error) {
  LogReader reader;
  if (!reader.open(path, error)) return false;
  const std::int64_t total = file_bytes(path);
  std::int64_t done = 0;
  LogEvent ev;
  loop_event_t loop_msg;
  trajectory_t traj_msg;
  TrajectoryAssembly assembly;
  std::unordered_map<std::int64_t, std::size_t> event_index;  ///< this log's event_id -> its place in input->loops
  while (reader.next(&ev)) {
    ++stats->events;
    done += LogReader::kEventHeaderBytes + static_cast<std::int64_t>(ev.channel.size() + ev.data.size());
    if (progress && (stats->events % 64) == 0) progress(done, total);
    if (ev.channel == ch.loop_event) {
      if (!LogReader::decode(ev, &loop_msg)) {
        ++stats->malformed;
        continue;
      }
      LoopDecision r;
      if (!from_message(loop_msg, &r, nullptr)) {
        ++stats->malformed;
        continue;
      }
      // An event_id seen again replaces the earlier event (lcmtypes/loop_event_t.lcm: keyed by event_id, keep the last).
      const auto seen = event_index.find(r.event_id);
      if (seen != event_index.end()) {
        input->loops[seen->second] = r;
        ++stats->repeated_events;
      } else {
        event_index.emplace(r.event_id, input->loops.size());
        input->loops.push_back(r);
      }
      ++stats->loop_events;
    } else if (ev.channel == ch.trajectory) {
      if (!decode_any_trajectory(ev.data.data(), ev.data.size(), &traj_msg)) {
        ++stats->malformed;
        continue;
      }
      ++stats->trajectories;
      // The LAST revision is the corrected trajectory (revisions increase with every correction): partial messages
      // are applied on top of the last full one, by keyframe id.
      assembly.apply(traj_msg);
    } else {
      ++stats->skipped;
    }
  }
  if (progress) progress(total, total);
  if (assembly.has_revision()) {
    const trajectory_t last = assembly.current();
    stats->trajectory_revision = last.revision;
    input->corrected.clear();
    const bool has_sessions = last.keyframe_sessions.size() == last.keyframes.size();
    for (std::size_t i = 0; i < last.keyframes.size(); ++i) {
      const auto& k = last.keyframes[i];
      KeyframePose kp;
      kp.utime = k.utime;
      kp.T_map_sensor = make_isometry(k.position, k.orientation);
      kp.session = has_sessions ? last.keyframe_sessions[i] : 0;
      input->corrected.push_back(kp);
    }
    input->T_map_odom = from_row_major(last.T_map_odom);
    input->sessions.clear();
    for (const auto& a : last.sessions) input->sessions.push_back({a.session, a.anchored != 0});
  }
  return true;
}

void LogReadStats::add(const LogReadStats& o) {
  events += o.events;
  scans += o.scans;
  ground_truth += o.ground_truth;
  odometry += o.odometry;
  loop_events += o.loop_events;
  trajectories += o.trajectories;
  malformed += o.malformed;
  skipped += o.skipped;
  repeated_events += o.repeated_events;
}

void merge_drives(std::vector<EvalInput> drives, EvalInput* input) {
  const auto first_utime = [](const EvalInput& d) { return d.ground_truth.empty() ? std::int64_t{0} : d.ground_truth.front().utime; };
  std::stable_sort(drives.begin(), drives.end(), [&](const EvalInput& a, const EvalInput& b) { return first_utime(a) < first_utime(b); });
  for (auto& d : drives) {
    input->ground_truth.insert(input->ground_truth.end(), d.ground_truth.begin(), d.ground_truth.end());
    input->odometry.insert(input->odometry.end(), d.odometry.begin(), d.odometry.end());
    input->scan_utimes.insert(input->scan_utimes.end(), d.scan_utimes.begin(), d.scan_utimes.end());
  }
}

void merge_results(EvalInput&& part, const LogReadStats& part_stats, EvalInput* input, LogReadStats* stats) {
  input->loops.insert(input->loops.end(), part.loops.begin(), part.loops.end());
  const bool take = part_stats.trajectory_revision >= 0 && part.corrected.size() >= input->corrected.size();
  const std::int64_t revision = take ? part_stats.trajectory_revision : stats->trajectory_revision;
  stats->add(part_stats);
  stats->trajectory_revision = revision;
  if (!take) return;
  input->corrected = std::move(part.corrected);
  input->T_map_odom = part.T_map_odom;
  input->sessions = std::move(part.sessions);
}

}  // namespace loopd::tools
