// loopd-map trajectory: every keyframe's pose as loopd publishes it (or its odometry pose), in TUM or KITTI format.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <unistd.h>

#include "loopd/base/trajectory_io.hpp"
#include "map_commands.hpp"
#include "map_poses.hpp"
#include "tool_output.hpp"

namespace loopd::tools {
namespace {

/// @brief The poses to write.
struct MapTrajectory {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<double> stamps;  ///< [s] keyframe scan times
};

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
  KeyframePoses read;
  if (const StoreStatus st = read_keyframe_poses(store, trajectory.odometry, std::nullopt, options.progress, &read); !st.ok()) {
    std::cerr << "loopd-map: " << st.message << "\n";
    return kExitBadInput;
  }
  MapTrajectory t;
  for (const KeyframePose& p : read.poses) {
    t.poses.push_back(p.T);
    t.stamps.push_back(static_cast<double>(p.utime) * 1e-6);
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
    table.add({"from correction revision " + (read.correction_revision ? std::to_string(read.correction_revision) : std::string("(none)")),
               std::to_string(read.from_correction)});
    table.add({"after it (T_map_odom * T_odom_sensor)", std::to_string(read.after_correction)});
  }
  table.add({"written to", where});
  summary << table.str();
  if (options.json) {
    print_json_line({{"poses", t.poses.size()},
                     {"kind", kind},
                     {"format", trajectory.format},
                     {"correction_revision", read.correction_revision},
                     {"from_correction", read.from_correction},
                     {"after_correction", read.after_correction},
                     {"out", where}});
  }
  return kExitOk;
}

}  // namespace loopd::tools
