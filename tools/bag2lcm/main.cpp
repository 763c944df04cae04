// bag2lcm: converts a ROS 1 bag (lidar scans, odometry or TF, optional ground truth) into an lcm-logger drive log
// that loopd --replay and loopd-eval read as they read loopd-sim's. The bag is read by Debian's rosbag_storage.
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <new>
#include <set>

#include "converter.hpp"
#include "report.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd::bag2lcm;

namespace {

int finish(const Report& r, bool json) {
  if (r.converted) std::cout << report_table(r);
  if (!r.ok) std::cerr << "bag2lcm: " << r.error << " (nothing written to " << r.out << ")\n";
  if (json) loopd::tools::print_json_line(report_json(r));
  return r.ok ? loopd::tools::kExitOk : loopd::tools::kExitUsage;  // a bag it cannot convert is bad input (exit_codes.hpp)
}

/// rosbag_storage trusts the lengths inside a bag (a damaged record header can make it read outside its buffers), so
/// the conversion runs in a child process: a crash there becomes an error that says where it happened.
int convert_isolated(const Options& options, bool json) {
  void* shared = mmap(nullptr, sizeof(Position), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (shared == MAP_FAILED) return finish(convert_bag(options, nullptr), json);
  Position* where = new (shared) Position();
  std::cout.flush();
  const pid_t pid = fork();
  if (pid < 0) return finish(convert_bag(options, where), json);
  if (pid == 0) {
    const int rc = finish(convert_bag(options, where), json);
    std::cout.flush();
    std::cerr.flush();
    _exit(rc);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  Report r;
  r.bag = options.bag;
  r.out = options.out;
  std::error_code ec;
  const auto bag_bytes = std::filesystem::file_size(options.bag, ec);
  r.bag_bytes = ec ? 0 : static_cast<std::int64_t>(bag_bytes);
  const int sig = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
  r.error = options.bag + ": rosbag_storage crashed (" + std::string(strsignal(sig)) + ") while " + where->phase + " at topic " + where->topic +
            " message " + std::to_string(where->index) + ": the bag is damaged there";
  std::filesystem::remove(options.out, ec);
  return finish(r, json);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"bag2lcm: ROS 1 bag -> LCM drive log (LIDAR_SCAN point_cloud_t, ODOMETRY_POSE and GROUND_TRUTH_POSE pose_t in the sensor frame)"};
  Options o;
  std::vector<std::string> tf;
  bool json = false, quiet = false;
  app.add_option("bag", o.bag, "ROS 1 bag (.bag; chunks stored as none, bz2 or lz4)")->required();
  app.add_option("--out", o.out, "output LCM log")->required();
  app.add_option("--cloud-topic", o.cloud_topic, "sensor_msgs/PointCloud2 topic of the lidar scans")->required();
  auto* odom = app.add_option("--odom-topic", o.odom_topic, "nav_msgs/Odometry topic of the odometry");
  auto* tf_opt = app.add_option("--tf", tf, "odometry from /tf instead: the chain FRAME_PARENT -> FRAME_CHILD (e.g. odom base_link)")
                     ->expected(2)
                     ->type_name("FRAME_PARENT FRAME_CHILD");
  odom->excludes(tf_opt);
  app.add_option("--gt-topic", o.gt_topic, "ground truth: nav_msgs/Odometry or geometry_msgs/PoseStamped topic");
  app.add_option("--imu-topic", o.imu_topic,
                 "sensor_msgs/Imu topic of a gyro: written on --imu-channel, its turn rate turned into the scans' frame by /tf_static "
                 "(as measured, and said so, when the IMU's frame is not connected to it)");
  app.add_option("--base-frame", o.base_frame, "the body the odometry gives the pose of (default: its child_frame_id, or FRAME_CHILD)");
  app.add_option("--gt-frame", o.gt_frame, "the body of the ground truth (default: an Odometry's child_frame_id, else the base frame)");
  app.add_option("--sensor-frame", o.sensor_frame, "frame of every scan (default: the first scan's frame_id; other frame_ids are skipped)");
  app.add_option("--tf-topic", o.tf_topic)->capture_default_str();
  app.add_option("--tf-static-topic", o.tf_static_topic, "static transforms, between the base frame and the scans' frame")->capture_default_str();
  app.add_option("--rings", o.rings, "number of rings (default: largest ring index + 1, rounded up to a multiple of 8)");
  app.add_option("--max-points", o.max_points, "scans with more points (width x height) are skipped")->capture_default_str();
  app.add_option("--scan-channel", o.scan_channel)->capture_default_str();
  app.add_option("--odometry-channel", o.odom_channel)->capture_default_str();
  app.add_option("--ground-truth-channel", o.gt_channel)->capture_default_str();
  app.add_option("--imu-channel", o.imu_channel)->capture_default_str();
  app.add_flag("--json", json, "print one JSON object as the last stdout line");
  app.add_flag("--quiet", quiet, "no progress bar");
  app.footer(
      "Scans: every PointCloud2 on --cloud-topic with float32/float64 x y z, optional intensity, ring or laser_id (any integer type), "
      "per-point time, t, timestamp or offset_time; NaN points dropped. Poses: T_world_sensor = T_world_base * T_base_sensor (T_base_sensor from "
      "--tf-static-topic). "
      "Exit status 0: converted; 1: the bag cannot be converted (the error names the topic and message); 2 or above 100: bad arguments.");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  if (tf.size() == 2) {
    o.tf_parent = tf[0];
    o.tf_child = tf[1];
  } else if (o.odom_topic.empty()) {
    std::cerr << "bag2lcm: give --odom-topic TOPIC or --tf FRAME_PARENT FRAME_CHILD\n";
    return 2;
  }
  const std::string pose_topic = o.odom_topic.empty() ? o.tf_topic : o.odom_topic;
  const std::set<std::string> distinct{o.cloud_topic, pose_topic, o.gt_topic.empty() ? o.cloud_topic : o.gt_topic,
                                       o.imu_topic.empty() ? o.cloud_topic : o.imu_topic};
  const std::size_t expected = 2 + (o.gt_topic.empty() ? 0 : 1) + (o.imu_topic.empty() ? 0 : 1);
  if (distinct.size() != expected) {
    std::cerr << "bag2lcm: the scan, odometry (or --tf-topic), ground-truth and IMU topics must differ\n";
    return 2;
  }
  if (o.rings < 0 || o.rings > 512) {
    std::cerr << "bag2lcm: --rings must be in 0..512\n";
    return 2;
  }
  o.progress = !quiet;
  return convert_isolated(o, json);
}
