// kitti2lcm: converts a KITTI odometry sequence into an lcm-logger drive log (scans in the lidar frame, ground
// truth on GROUND_TRUTH_POSE, odometry on ODOMETRY_POSE from a file or from ground truth with injected drift).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "lcm_log.hpp"
#include "loopd/base/lidar_model.hpp"
#include "loopd/eval/odometry_drift.hpp"
#include "loopd/base/trajectory_io.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/io/kitti_files.hpp"
#include "message_convert.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;
using namespace loopd::tools;
namespace fs = std::filesystem;

namespace {

/// The scan of a frame: NNNNNN.bin, else .pcd or .ply (any cloud format read_cloud_file reads).
std::string scan_path(const std::string& velodyne_dir, std::size_t frame) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06zu", frame);
  for (const char* ext : {".bin", ".pcd", ".ply"}) {
    const std::string p = velodyne_dir + "/" + name + ext;
    std::error_code ec;  // the non-throwing overloads: a permission error must not abort the tool
    if (fs::exists(p, ec)) return p;
  }
  return {};
}

pose_t pose_message(std::int64_t utime, std::int64_t seq, const Eigen::Isometry3d& T, double residual) {
  StampedPose p;
  p.utime = utime;
  p.T_world_sensor = T;
  p.residual = residual;
  return to_message(p, seq);
}

/// Rings from the elevation of each point (nearest beam of the model; points outside the fan go to the nearest
/// edge ring). Approximate: real sensors' per-beam calibration differs from the nominal angles by about 0.1 deg.
void assign_rings(const LidarModel& model, PointCloud* cloud) {
  cloud->ring.resize(cloud->size());
  cloud->num_rings = model.num_rings;
  const double lowest = model.vertical_angles_deg.front() * M_PI / 180.0;
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    const Eigen::Vector3d p = cloud->points[i].cast<double>();
    const double elevation = std::atan2(p.z(), std::hypot(p.x(), p.y()));
    int r = ring_from_elevation(model, elevation);
    if (r < 0) r = elevation < lowest ? 0 : model.num_rings - 1;
    cloud->ring[i] = static_cast<std::uint16_t>(r);
  }
}

/// Prints the reason; returns kExitUsage (bad input) unless told otherwise (a write that failed on the way).
int fail(const std::string& msg, int status = loopd::tools::kExitUsage) {
  std::cerr << "kitti2lcm: " << msg << "\n";
  return status;
}

struct Options {
  std::string sequence, poses_path, out, calib_path, times_path, odometry_path, frame = "velodyne", sensor;
  std::int64_t first_frame = 0, max_frames = -1, utime_offset = 1000000;
  double period = 0.0;
  bool skip_missing = false, json = false, quiet = false;
  OdometryDriftConfig drift;
  std::string scan_channel = channels::kScan, gt_channel = channels::kGroundTruth, odom_channel = channels::kPose;
};

void add_options(CLI::App& app, Options& o) {
  app.add_option("--sequence", o.sequence, "sequence folder: sequences/NN (scans in NN/velodyne/NNNNNN.bin) or a folder holding the scans")
      ->required();
  app.add_option("--poses", o.poses_path, "ground-truth poses poses/NN.txt (KITTI, camera frame)")->required();
  app.add_option("--out", o.out, "output LCM log")->required();
  app.add_option("--calib", o.calib_path, "calibration with the 'Tr:' line (default: SEQUENCE/calib.txt)");
  app.add_option("--times", o.times_path, "timestamps [s], one a line (default: SEQUENCE/times.txt)");
  app.add_option("--period", o.period, "[s] scan period when there is no times file (e.g. 0.1)");
  app.add_option("--odometry", o.odometry_path, "odometry poses (KITTI format, camera frame) instead of injected drift");
  app.add_option("--drift-seed", o.drift.seed, "seed of the injected odometry drift")->capture_default_str();
  app.add_option("--heading-bias", o.drift.heading_bias_deg_per_m, "[deg/m] injected yaw bias")->capture_default_str();
  app.add_option("--scale-bias", o.drift.scale_bias, "injected relative step-length error")->capture_default_str();
  app.add_option("--yaw-walk", o.drift.yaw_random_walk_deg, "[deg/sqrt(step)] injected yaw random walk")->capture_default_str();
  app.add_option("--translation-noise", o.drift.translation_noise, "[m/sqrt(step)] injected translation noise")->capture_default_str();
  app.add_option("--residual-base", o.drift.residual_base, "[m] residual of an unperturbed step")->capture_default_str();
  app.add_option("--first-frame", o.first_frame,
                 "start at this frame (its pose, time and scan NNNNNN): the rest of a drive as a drive of its own, e.g. a map made of its first "
                 "half and its second half localized in it")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-frames", o.max_frames, "convert at most this many frames");
  app.add_option("--utime-offset", o.utime_offset, "[us] added to times (utime = offset + time * 1e6)")->capture_default_str();
  app.add_option("--sensor", o.sensor, "fill ring indices from point elevations with this lidar model (KITTI: hdl64); default: no rings");
  app.add_option("--frame", o.frame, "sensor frame name in point_cloud_t")->capture_default_str();
  app.add_flag("--skip-missing-scans", o.skip_missing, "frames without a scan file still get poses (default: a missing scan is an error)");
  app.add_option("--scan-channel", o.scan_channel)->capture_default_str();
  app.add_option("--ground-truth-channel", o.gt_channel)->capture_default_str();
  app.add_option("--odometry-channel", o.odom_channel)->capture_default_str();
  app.add_flag("--json", o.json, "print one JSON object as the last stdout line");
  app.add_flag("--quiet", o.quiet, "no progress bar");
}

/// @brief What is converted: the lidar's ground truth and odometry poses, the scan times, the number of frames.
struct Sequence {
  std::string velodyne_dir;
  std::vector<Eigen::Isometry3d> gt, odom;
  std::vector<double> times, residuals;
  std::size_t first = 0;  ///< frame number of gt[0] (--first-frame)
  std::size_t n = 0;
};

/// @brief The times of every pose: the times file, or the period. Returns an error, or nothing.
std::optional<std::string> read_times(Options& o, Sequence& s) {
  std::error_code fs_error;
  if (o.times_path.empty() && fs::exists(o.sequence + "/times.txt", fs_error)) o.times_path = o.sequence + "/times.txt";
  if (!o.times_path.empty()) {
    KittiTimes read = read_kitti_times(o.times_path);
    if (!read.ok) return read.error;
    s.times = std::move(read.seconds);
    if (s.times.size() < s.gt.size())
      return o.times_path + " has " + std::to_string(s.times.size()) + " times but " + o.poses_path + " has " + std::to_string(s.gt.size()) +
             " poses";
  } else if (o.period > 0.0) {
    for (std::size_t i = 0; i < s.gt.size(); ++i) s.times.push_back(static_cast<double>(i) * o.period);
  } else {
    return "no times file (" + o.sequence + "/times.txt not found): give --times FILE or --period SECONDS";
  }
  return std::nullopt;
}

/// @brief The odometry: a given file's, or the ground truth with injected drift. Returns an error, or nothing.
std::optional<std::string> make_odometry(const Options& o, const Eigen::Isometry3d& T_cam_velo, Sequence& s) {
  if (!o.odometry_path.empty()) {
    const TrajectoryFile cam_odom = read_trajectory(o.odometry_path, TrajectoryFormat::kKitti);
    if (!cam_odom.ok) return cam_odom.error;
    if (cam_odom.poses.size() < s.first + s.n)
      return o.odometry_path + " has " + std::to_string(cam_odom.poses.size()) + " poses, fewer than the " + std::to_string(s.n) +
             " frames converted";
    s.odom = kitti_camera_to_lidar(cam_odom.poses, T_cam_velo);
    s.odom.erase(s.odom.begin(), s.odom.begin() + static_cast<long>(std::min(s.first, s.odom.size())));
    s.residuals.assign(s.odom.size(), 0.0);
    return std::nullopt;
  }
  const std::vector<Eigen::Isometry3d> head(s.gt.begin(), s.gt.begin() + static_cast<long>(s.n));
  OdometryDriftResult dr = inject_odometry_drift(head, o.drift);
  s.odom = std::move(dr.poses);
  s.residuals = std::move(dr.residuals);
  return std::nullopt;
}

/// @brief Reads the sequence's calibration, poses, times and odometry. Returns an error, or nothing.
std::optional<std::string> read_sequence(Options& o, Sequence& s) {
  std::error_code fs_error;  // the non-throwing overloads: a permission error must not abort the tool
  if (!fs::is_directory(o.sequence, fs_error)) return "sequence folder " + o.sequence + " does not exist";
  s.velodyne_dir = fs::is_directory(o.sequence + "/velodyne", fs_error) ? o.sequence + "/velodyne" : o.sequence;
  if (o.calib_path.empty()) o.calib_path = o.sequence + "/calib.txt";
  if (!fs::exists(o.calib_path, fs_error)) return "calibration file " + o.calib_path + " not found (give it with --calib)";
  const KittiCalibration calib = read_kitti_calib_tr(o.calib_path);
  if (!calib.ok) return calib.error;
  const TrajectoryFile cam_poses = read_trajectory(o.poses_path, TrajectoryFormat::kKitti);
  if (!cam_poses.ok) return cam_poses.error;
  s.gt = kitti_camera_to_lidar(cam_poses.poses, calib.T_cam_velo);
  if (auto e = read_times(o, s)) return e;
  if (o.first_frame > 0) {
    if (static_cast<std::size_t>(o.first_frame) >= s.gt.size())
      return "--first-frame " + std::to_string(o.first_frame) + " is past the last of the " + std::to_string(s.gt.size()) + " poses";
    s.first = static_cast<std::size_t>(o.first_frame);
    s.gt.erase(s.gt.begin(), s.gt.begin() + o.first_frame);
    s.times.erase(s.times.begin(), s.times.begin() + o.first_frame);  // read_times gave at least one per pose
  }
  s.n = s.gt.size();
  if (o.max_frames >= 0) s.n = std::min(s.n, static_cast<std::size_t>(o.max_frames));
  if (s.n == 0) return std::string("nothing to convert (--max-frames 0)");
  return make_odometry(o, calib.T_cam_velo, s);
}

struct Written {
  std::int64_t scans = 0, missing = 0, points = 0;
};

/// @brief Writes every frame's poses and scan. Returns the exit status when it cannot.
std::optional<int> write_log(const Options& o, const Sequence& s, const std::optional<LidarModel>& model, Written& w) {
  LogWriter writer;
  std::string error;
  if (!writer.open(o.out, &error)) return fail(error);
  Progress bar("kitti2lcm", static_cast<std::int64_t>(s.n), !o.quiet);
  PointCloud cloud;
  for (std::size_t i = 0; i < s.n; ++i) {
    const std::int64_t utime = o.utime_offset + static_cast<std::int64_t>(std::llround(s.times[i] * 1e6));
    const auto seq = static_cast<std::int64_t>(i);
    if (!writer.write_message(o.gt_channel, utime, pose_message(utime, seq, s.gt[i], 0.0)) ||
        !writer.write_message(o.odom_channel, utime, pose_message(utime, seq, s.odom[i], s.residuals[i])))
      return fail("cannot write to " + o.out, loopd::tools::kExitProblem);
    const std::string scan = scan_path(s.velodyne_dir, s.first + i);
    if (scan.empty()) {
      if (!o.skip_missing) {
        char name[32];
        std::snprintf(name, sizeof(name), "%06zu.bin", s.first + i);
        return fail("scan " + s.velodyne_dir + "/" + name + " not found (frame " + std::to_string(s.first + i) +
                    "; --skip-missing-scans writes poses without it, --max-frames converts fewer frames)");
      }
      ++w.missing;
    } else {
      CloudFile read = read_cloud_file(scan);
      if (!read.ok) return fail(read.error);
      cloud = std::move(read.cloud);
      if (model) assign_rings(*model, &cloud);
      cloud.time.clear();  // KITTI scans have no per-point times: point_cloud_t.num_point_times = 0 (unknown)
      if (!writer.write_message(o.scan_channel, utime, to_message(cloud, utime, seq, o.frame)))
        return fail("cannot write to " + o.out, loopd::tools::kExitProblem);
      ++w.scans;
      w.points += static_cast<std::int64_t>(cloud.size());
    }
    bar.update(static_cast<std::int64_t>(i + 1));
  }
  bar.finish();
  writer.close();
  return std::nullopt;
}

void report(const Options& o, const Sequence& s, const Written& w) {
  std::error_code ec;
  const auto bytes = static_cast<std::int64_t>(fs::file_size(o.out, ec));
  const double final_error = (s.odom[s.n - 1].translation() - s.gt[s.n - 1].translation()).norm();
  Table t({"kitti2lcm", "value"});
  t.add({"frames", std::to_string(s.n)});
  t.add({"scans written", std::to_string(w.scans)});
  t.add({"frames without scan", std::to_string(w.missing)});
  t.add({"points per scan (mean)", w.scans > 0 ? std::to_string(w.points / w.scans) : "-"});
  t.add({"odometry", o.odometry_path.empty() ? "ground truth + drift (seed " + std::to_string(o.drift.seed) + ")" : o.odometry_path});
  t.add({"final odometry error [m]", fmt(final_error)});
  t.add({"output", o.out + " (" + fmt(static_cast<double>(bytes) / 1e6, 1) + " MB)"});
  std::cout << t.str();
  if (o.json)
    print_json_line({{"frames", s.n},
                     {"scans", w.scans},
                     {"missing_scans", w.missing},
                     {"points", w.points},
                     {"bytes", bytes},
                     {"final_odometry_error", final_error},
                     {"out", o.out}});
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kitti2lcm: KITTI odometry sequence -> LCM drive log (LIDAR_SCAN, GROUND_TRUTH_POSE, ODOMETRY_POSE)"};
  Options o;
  add_options(app, o);
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  if (auto e = o.drift.validate()) return fail(*e);
  std::optional<LidarModel> model;
  if (!o.sensor.empty()) {
    model = lidar_model_from_name(o.sensor);
    if (!model) return fail("unknown --sensor '" + o.sensor + "'");
  }
  Sequence s;
  if (auto e = read_sequence(o, s)) return fail(*e);
  Written w;
  if (auto rc = write_log(o, s, model, w)) return *rc;
  report(o, s, w);
  return loopd::tools::kExitOk;
}
