// loopd-map trajectory: every keyframe's pose as loopd publishes it (or its odometry pose), in TUM or KITTI format.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <unistd.h>

#include "loopd/core/trajectory_io.hpp"
#include "map_commands.hpp"
#include "tool_output.hpp"

namespace loopd::tools {
namespace {

/// @brief The poses to write and where they came from.
struct MapTrajectory {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<double> stamps;         ///< [s] keyframe scan times
  std::int64_t from_correction = 0;   ///< poses the stored correction holds
  std::int64_t after_correction = 0;  ///< poses mapped with the correction's T_map_odom (keyframes it does not cover)
};

/// @brief Corrected pose of a keyframe: the stored correction's T_map_sensor where it covers the keyframe, else
/// T_map_odom * T_odom_sensor (identity T_map_odom before any correction), as loopd publishes a later keyframe.
void collect_pose(const MapKeyframe& k, const CorrectionRecord* correction, const std::map<KeyframeKey, std::size_t>& covered, bool odometry,
                  MapTrajectory* out) {
  out->stamps.push_back(static_cast<double>(k.record.utime) * 1e-6);
  if (odometry) {
    out->poses.push_back(k.record.T_odom_sensor);
    return;
  }
  const auto it = covered.find(k.record.key);
  if (it != covered.end()) {
    out->poses.push_back(correction->T_map_sensor[it->second]);
    ++out->from_correction;
    return;
  }
  out->poses.push_back(correction ? correction->T_map_odom * k.record.T_odom_sensor : k.record.T_odom_sensor);
  ++out->after_correction;
}

StoreStatus read_trajectory_poses(MapStore& store, const CorrectionRecord* correction, bool odometry, bool progress, MapTrajectory* out) {
  std::map<KeyframeKey, std::size_t> covered;
  if (correction && !odometry)
    for (std::size_t i = 0; i < correction->keys.size(); ++i) covered.emplace(correction->keys[i], i);
  const StoreResult<MapStats> stats = store.stats();
  Progress bar("reading keyframes", stats.ok() ? stats.value.keyframes : 0, progress);
  const StoreStatus read = store.for_each_keyframe(std::nullopt, KeyframeLoad::kPose, [&](MapKeyframe&& k) {
    collect_pose(k, correction, covered, odometry, out);
    bar.update(static_cast<std::int64_t>(out->poses.size()));
  });
  bar.finish();
  return read;
}

/// @brief Writes to stdout through a temporary file (the writer takes a path; /dev/stdout would truncate a redirect).
std::optional<std::string> write_to_stdout(const MapTrajectory& t, TrajectoryFormat format) {
  char name[] = "/tmp/loopd-map-trajectory-XXXXXX";
  const int fd = ::mkstemp(name);
  if (fd < 0) return std::string("cannot create a temporary file in /tmp");
  ::close(fd);
  auto error = write_trajectory(name, t.poses, t.stamps, format);
  if (!error) {
    std::ifstream in(name, std::ios::binary);
    std::cout << in.rdbuf();
    std::cout.flush();
    if (!std::cout) error = "write to stdout failed";
  }
  std::remove(name);
  return error;
}

}  // namespace

int run_trajectory(MapStore& store, const TrajectoryOptions& trajectory, const CommandOptions& options) {
  const std::optional<TrajectoryFormat> format = trajectory_format_from_string(trajectory.format);
  if (!format) {
    std::cerr << "loopd-map: trajectory format \"" << trajectory.format << "\": expected tum or kitti\n";
    return kExitBadInput;
  }
  const StoreResult<std::optional<CorrectionRecord>> correction = store.correction();
  if (!correction.ok()) {
    std::cerr << "loopd-map: " << correction.status.message << "\n";
    return kExitBadInput;
  }
  const CorrectionRecord* stored = correction.value ? &*correction.value : nullptr;
  MapTrajectory t;
  if (const StoreStatus read = read_trajectory_poses(store, stored, trajectory.odometry, options.progress, &t); !read.ok()) {
    std::cerr << "loopd-map: " << read.message << "\n";
    return kExitBadInput;
  }
  const auto error = trajectory.out.empty() ? write_to_stdout(t, *format) : write_trajectory(trajectory.out, t.poses, t.stamps, *format);
  if (error) {
    std::cerr << "loopd-map: " << *error << "\n";
    return kExitBadInput;
  }
  const std::string kind = trajectory.odometry ? "odometry" : "corrected";
  const std::string where = trajectory.out.empty() ? "stdout" : trajectory.out;
  // The summary goes where it cannot mix with poses written to stdout.
  std::ostream& summary = trajectory.out.empty() ? std::cerr : std::cout;
  Table table({"", "value"});
  table.add({"poses (" + kind + ", " + trajectory.format + ")", std::to_string(t.poses.size())});
  if (!trajectory.odometry) {
    table.add({"from correction revision " + (stored ? std::to_string(stored->revision) : std::string("(none)")), std::to_string(t.from_correction)});
    table.add({"after it (T_map_odom * T_odom_sensor)", std::to_string(t.after_correction)});
  }
  table.add({"written to", where});
  summary << table.str();
  if (options.json) {
    print_json_line({{"poses", t.poses.size()},
                     {"kind", kind},
                     {"format", trajectory.format},
                     {"correction_revision", stored ? stored->revision : 0},
                     {"from_correction", t.from_correction},
                     {"after_correction", t.after_correction},
                     {"out", where}});
  }
  return kExitOk;
}

}  // namespace loopd::tools
