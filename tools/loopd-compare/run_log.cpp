#include "run_log.hpp"

#include <unordered_map>
#include <loopd/loop_event_t.hpp>
#include <loopd/trajectory_t.hpp>

#include "lcm_log.hpp"
#include "loop_event_convert.hpp"
#include "trajectory_assembly.hpp"
#include "loopd/base/pose.hpp"

namespace loopd::tools {
namespace {

std::vector<TrajectoryPose> keyframes_of(const trajectory_t& msg) {
  std::vector<TrajectoryPose> out;
  out.reserve(msg.keyframes.size());
  for (std::size_t i = 0; i < msg.keyframes.size(); ++i) {
    const keyframe_pose_t& k = msg.keyframes[i];
    TrajectoryPose r;
    r.session = i < msg.keyframe_sessions.size() ? msg.keyframe_sessions[i] : 0;  // 0 in logs before sessions
    r.id = k.id;
    r.position = Eigen::Vector3d(k.position[0], k.position[1], k.position[2]);
    r.orientation = Eigen::Quaterniond(k.orientation[0], k.orientation[1], k.orientation[2], k.orientation[3]);
    out.push_back(r);
  }
  return out;
}

void note_malformed(RunLog* run, const std::string& channel, const std::string& why) {
  if (run->malformed++ == 0) run->first_malformed = channel + " event " + std::to_string(run->events) + ": " + why;
}

}  // namespace

bool read_run_log(const std::string& path, const CompareChannels& channels, RunLog* run, std::string* error) {
  LogReader reader;
  if (!reader.open(path, error)) return false;
  LogEvent ev;
  loop_event_t loop_msg;
  trajectory_t traj_msg;
  TrajectoryAssembly assembly;
  std::string why;
  std::unordered_map<std::int64_t, std::size_t> event_index;  ///< event_id -> its place in run->decisions
  while (reader.next(&ev)) {
    ++run->events;
    if (ev.channel == channels.loop_event) {
      LoopDecision d;
      if (!LogReader::decode(ev, &loop_msg, &why) || !from_message(loop_msg, &d, &why)) {
        note_malformed(run, ev.channel, why);
        continue;
      }
      // An event_id seen again replaces the earlier event (lcmtypes/loop_event_t.lcm: keyed by event_id, keep the last).
      const auto seen = event_index.find(d.event_id);
      if (seen != event_index.end()) {
        run->decisions[seen->second] = std::move(d);
        ++run->repeated_events;
      } else {
        event_index.emplace(d.event_id, run->decisions.size());
        run->decisions.push_back(std::move(d));
      }
    } else if (ev.channel == channels.trajectory) {
      if (!decode_any_trajectory(ev.data.data(), ev.data.size(), &traj_msg, &why)) {
        note_malformed(run, ev.channel, why);
        continue;
      }
      // Revisions, not messages: the full snapshot at the end of a replay repeats the last revision.
      if (!assembly.has_revision() || traj_msg.revision != assembly.revision()) ++run->revisions;
      // The LAST revision is the corrected trajectory (revisions increase with every correction): partial messages
      // are applied on top of the last full one, by keyframe id.
      assembly.apply(traj_msg);
    }
  }
  if (assembly.has_revision()) {
    run->last_revision = assembly.revision();
    run->trajectory = keyframes_of(assembly.current());
  }
  run->problems = reader.problems();
  if (assembly.has_revision() && !assembly.complete()) {
    if (!run->problems.empty()) run->problems += "; ";
    run->problems += "trajectory revision " + std::to_string(assembly.revision()) + ": " + std::to_string(run->trajectory.size()) +
                     " keyframes rebuilt, its message announced " + std::to_string(assembly.current().total_keyframes) +
                     (assembly.snapshots() == 0 ? " (no full snapshot in the log)" : " (a trajectory message is missing)");
  }
  if (run->decisions.empty() && run->revisions == 0 && run->malformed == 0) {
    if (error) {
      *error = path + ": no '" + channels.loop_event + "' or '" + channels.trajectory + "' events in " + std::to_string(run->events) +
               " LCM events (not a loopd output log?)";
      if (!run->problems.empty()) *error += "; " + run->problems;
    }
    return false;
  }
  return true;
}

}  // namespace loopd::tools
