// kitti2lcm: converts a KITTI odometry sequence into an lcm-logger drive log (scans in the lidar frame, ground
// truth on GROUND_TRUTH_POSE, odometry on ODOMETRY_POSE from a file or from ground truth with injected drift).
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "lcm_log.hpp"
#include "loopd/core/lidar_model.hpp"
#include "loopd/eval/odometry_drift.hpp"
#include "loopd/core/trajectory_io.hpp"
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kitti2lcm: KITTI odometry sequence -> LCM drive log (LIDAR_SCAN, GROUND_TRUTH_POSE, ODOMETRY_POSE)"};
  std::string sequence, poses_path, out, calib_path, times_path, odometry_path, frame = "velodyne", sensor;
  std::int64_t max_frames = -1, utime_offset = 1000000;
  double period = 0.0;
  bool skip_missing = false, json = false, quiet = false;
  OdometryDriftConfig drift;
  std::string scan_channel = channels::kScan, gt_channel = channels::kGroundTruth, odom_channel = channels::kPose;
  app.add_option("--sequence", sequence, "sequence folder: sequences/NN (scans in NN/velodyne/NNNNNN.bin) or a folder holding the scans")->required();
  app.add_option("--poses", poses_path, "ground-truth poses poses/NN.txt (KITTI, camera frame)")->required();
  app.add_option("--out", out, "output LCM log")->required();
  app.add_option("--calib", calib_path, "calibration with the 'Tr:' line (default: SEQUENCE/calib.txt)");
  app.add_option("--times", times_path, "timestamps [s], one a line (default: SEQUENCE/times.txt)");
  app.add_option("--period", period, "[s] scan period when there is no times file (e.g. 0.1)");
  app.add_option("--odometry", odometry_path, "odometry poses (KITTI format, camera frame) instead of injected drift");
  app.add_option("--drift-seed", drift.seed, "seed of the injected odometry drift")->capture_default_str();
  app.add_option("--heading-bias", drift.heading_bias_deg_per_m, "[deg/m] injected yaw bias")->capture_default_str();
  app.add_option("--scale-bias", drift.scale_bias, "injected relative step-length error")->capture_default_str();
  app.add_option("--yaw-walk", drift.yaw_random_walk_deg, "[deg/sqrt(step)] injected yaw random walk")->capture_default_str();
  app.add_option("--translation-noise", drift.translation_noise, "[m/sqrt(step)] injected translation noise")->capture_default_str();
  app.add_option("--residual-base", drift.residual_base, "[m] residual of an unperturbed step")->capture_default_str();
  app.add_option("--max-frames", max_frames, "convert at most this many frames");
  app.add_option("--utime-offset", utime_offset, "[us] added to times (utime = offset + time * 1e6)")->capture_default_str();
  app.add_option("--sensor", sensor, "fill ring indices from point elevations with this lidar model (KITTI: hdl64); default: no rings");
  app.add_option("--frame", frame, "sensor frame name in point_cloud_t")->capture_default_str();
  app.add_flag("--skip-missing-scans", skip_missing, "frames without a scan file still get poses (default: a missing scan is an error)");
  app.add_option("--scan-channel", scan_channel)->capture_default_str();
  app.add_option("--ground-truth-channel", gt_channel)->capture_default_str();
  app.add_option("--odometry-channel", odom_channel)->capture_default_str();
  app.add_flag("--json", json, "print one JSON object as the last stdout line");
  app.add_flag("--quiet", quiet, "no progress bar");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  if (auto e = drift.validate()) return fail(*e);
  std::optional<LidarModel> model;
  if (!sensor.empty()) {
    model = lidar_model_from_name(sensor);
    if (!model) return fail("unknown --sensor '" + sensor + "'");
  }

  std::error_code fs_error;  // the non-throwing overloads: a permission error must not abort the tool
  if (!fs::is_directory(sequence, fs_error)) return fail("sequence folder " + sequence + " does not exist");
  const std::string velodyne_dir = fs::is_directory(sequence + "/velodyne", fs_error) ? sequence + "/velodyne" : sequence;
  if (calib_path.empty()) calib_path = sequence + "/calib.txt";
  std::string error;
  if (!fs::exists(calib_path, fs_error)) return fail("calibration file " + calib_path + " not found (give it with --calib)");
  const KittiCalibration calib = read_kitti_calib_tr(calib_path);
  if (!calib.ok) return fail(calib.error);
  const Eigen::Isometry3d& T_cam_velo = calib.T_cam_velo;
  const TrajectoryFile cam_poses = read_trajectory(poses_path, TrajectoryFormat::kKitti);
  if (!cam_poses.ok) return fail(cam_poses.error);
  const std::vector<Eigen::Isometry3d> gt = kitti_camera_to_lidar(cam_poses.poses, T_cam_velo);

  std::vector<double> times;
  if (times_path.empty() && fs::exists(sequence + "/times.txt", fs_error)) times_path = sequence + "/times.txt";
  if (!times_path.empty()) {
    KittiTimes read = read_kitti_times(times_path);
    if (!read.ok) return fail(read.error);
    times = std::move(read.seconds);
    if (times.size() < gt.size())
      return fail(times_path + " has " + std::to_string(times.size()) + " times but " + poses_path + " has " + std::to_string(gt.size()) + " poses");
  } else if (period > 0.0) {
    for (std::size_t i = 0; i < gt.size(); ++i) times.push_back(static_cast<double>(i) * period);
  } else {
    return fail("no times file (" + sequence + "/times.txt not found): give --times FILE or --period SECONDS");
  }

  std::size_t n = gt.size();
  if (max_frames >= 0) n = std::min(n, static_cast<std::size_t>(max_frames));
  if (n == 0) return fail("nothing to convert (--max-frames 0)");
  std::vector<Eigen::Isometry3d> odom;
  std::vector<double> residuals;
  if (!odometry_path.empty()) {
    const TrajectoryFile cam_odom = read_trajectory(odometry_path, TrajectoryFormat::kKitti);
    if (!cam_odom.ok) return fail(cam_odom.error);
    if (cam_odom.poses.size() < n)
      return fail(odometry_path + " has " + std::to_string(cam_odom.poses.size()) + " poses, fewer than the " + std::to_string(n) +
                  " frames converted");
    odom = kitti_camera_to_lidar(cam_odom.poses, T_cam_velo);
    residuals.assign(odom.size(), 0.0);
  } else {
    const std::vector<Eigen::Isometry3d> head(gt.begin(), gt.begin() + static_cast<long>(n));
    OdometryDriftResult dr = inject_odometry_drift(head, drift);
    odom = std::move(dr.poses);
    residuals = std::move(dr.residuals);
  }

  LogWriter writer;
  if (!writer.open(out, &error)) return fail(error);
  Progress bar("kitti2lcm", static_cast<std::int64_t>(n), !quiet);
  std::int64_t scans = 0, missing = 0, points = 0;
  PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t utime = utime_offset + static_cast<std::int64_t>(std::llround(times[i] * 1e6));
    const auto seq = static_cast<std::int64_t>(i);
    if (!writer.write_message(gt_channel, utime, pose_message(utime, seq, gt[i], 0.0)) ||
        !writer.write_message(odom_channel, utime, pose_message(utime, seq, odom[i], residuals[i])))
      return fail("cannot write to " + out, loopd::tools::kExitProblem);
    const std::string scan = scan_path(velodyne_dir, i);
    if (scan.empty()) {
      if (!skip_missing) {
        char name[32];
        std::snprintf(name, sizeof(name), "%06zu.bin", i);
        return fail("scan " + velodyne_dir + "/" + name + " not found (frame " + std::to_string(i) +
                    "; --skip-missing-scans writes poses without it, --max-frames converts fewer frames)");
      }
      ++missing;
    } else {
      CloudFile read = read_cloud_file(scan);
      if (!read.ok) return fail(read.error);
      cloud = std::move(read.cloud);
      if (model) assign_rings(*model, &cloud);
      cloud.time.clear();  // KITTI scans have no per-point times: point_cloud_t.num_point_times = 0 (unknown)
      if (!writer.write_message(scan_channel, utime, to_message(cloud, utime, seq, frame)))
        return fail("cannot write to " + out, loopd::tools::kExitProblem);
      ++scans;
      points += static_cast<std::int64_t>(cloud.size());
    }
    bar.update(static_cast<std::int64_t>(i + 1));
  }
  bar.finish();
  writer.close();
  std::error_code ec;
  const auto bytes = static_cast<std::int64_t>(fs::file_size(out, ec));

  Table t({"kitti2lcm", "value"});
  t.add({"frames", std::to_string(n)});
  t.add({"scans written", std::to_string(scans)});
  t.add({"frames without scan", std::to_string(missing)});
  t.add({"points per scan (mean)", scans > 0 ? std::to_string(points / scans) : "-"});
  t.add({"odometry", odometry_path.empty() ? "ground truth + drift (seed " + std::to_string(drift.seed) + ")" : odometry_path});
  t.add({"final odometry error [m]", fmt((odom[n - 1].translation() - gt[n - 1].translation()).norm())});
  t.add({"output", out + " (" + fmt(static_cast<double>(bytes) / 1e6, 1) + " MB)"});
  std::cout << t.str();
  if (json)
    print_json_line({{"frames", n},
                     {"scans", scans},
                     {"missing_scans", missing},
                     {"points", points},
                     {"bytes", bytes},
                     {"final_odometry_error", (odom[n - 1].translation() - gt[n - 1].translation()).norm()},
                     {"out", out}});
  return 0;
}
