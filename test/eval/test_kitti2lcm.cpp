// kitti2lcm round trip: a small synthetic KITTI-format folder written here, converted, and decoded back; the real
// KITTI 00 scans when ../shared/data is present. Also the KITTI readers of loopd_eval and their error messages.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "loopd/base/trajectory_io.hpp"
#include "loopd/io/kitti_files.hpp"
#include "loopd/io/cloud_file.hpp"
#include "support/data_dir.hpp"

#if 1  // LCM types and lcm_log.hpp are always linked (loopd_lcm)
#define LOOPD_EVAL_TEST_HAS_LCM 1
#include "lcm_log.hpp"
#include "message_convert.hpp"
#endif

using namespace loopd;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& tag) {
  const fs::path d = fs::temp_directory_path() / ("loopd_test_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream f(p);
  f << text;
}

std::string pose_line(const Eigen::Isometry3d& T) {
  std::ostringstream s;
  s.precision(12);
  const Eigen::Matrix4d M = T.matrix();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) s << M(r, c) << ((r == 2 && c == 3) ? "\n" : " ");
  return s.str();
}

// A KITTI-like Tr (velodyne -> camera): x_cam = -y_velo, y_cam = -z_velo, z_cam = x_velo, plus an offset.
Eigen::Isometry3d kitti_like_tr() {
  Eigen::Isometry3d Tr = Eigen::Isometry3d::Identity();
  Tr.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  Tr.translation() = Eigen::Vector3d(-0.004, -0.076, -0.27);
  return Tr;
}

Eigen::Isometry3d camera_pose(int i) {
  // Camera frame: forward is +z, the car turns about the camera's y axis (down).
  Eigen::Isometry3d P = Eigen::Isometry3d::Identity();
  P.linear() = Eigen::AngleAxisd(0.05 * i, Eigen::Vector3d::UnitY()).toRotationMatrix();
  P.translation() = Eigen::Vector3d(0.1 * i, -0.02 * i, 0.9 * i);
  return P;
}

std::string bin_dir() { return std::string(LOOPD_BINARY_DIR) + "/tools/kitti2lcm/kitti2lcm"; }

/// Writes sequences/07/{velodyne/00000{0,1,2}.bin, calib.txt, times.txt} and poses/07.txt.
void write_synthetic_kitti(const fs::path& root) {
  fs::create_directories(root / "sequences/07/velodyne");
  fs::create_directories(root / "poses");
  for (int i = 0; i < 3; ++i) {
    PointCloud c;
    for (int k = 0; k < 5 + i; ++k) {
      c.points.emplace_back(1.0f * static_cast<float>(k), -2.0f + static_cast<float>(i), 0.5f * static_cast<float>(k));
      c.intensity.push_back(0.1f * static_cast<float>(k));
    }
    char name[16];
    std::snprintf(name, sizeof(name), "%06d.bin", i);
    REQUIRE_FALSE(write_kitti_bin((root / "sequences/07/velodyne" / name).string(), c));
  }
  std::ostringstream calib;
  calib << "P0: 7.2e+02 0 6.0e+02 0 0 7.2e+02 1.8e+02 0 0 0 1 0\n"
        << "Tr: " << pose_line(kitti_like_tr());
  write_text(root / "sequences/07/calib.txt", calib.str());
  write_text(root / "sequences/07/times.txt", "0.000000e+00\n1.036150e-01\n2.072770e-01\n");
  std::string poses;
  for (int i = 0; i < 3; ++i) poses += pose_line(camera_pose(i));
  write_text(root / "poses/07.txt", poses);
}

}  // namespace

TEST_CASE("KITTI readers: poses, times, calib and camera-to-lidar conversion") {
  const fs::path d = temp_dir("kitti_readers");
  write_synthetic_kitti(d);
  const TrajectoryFile poses = read_trajectory((d / "poses/07.txt").string(), TrajectoryFormat::kKitti);
  REQUIRE(poses.ok);
  REQUIRE(poses.poses.size() == 3);
  CHECK(poses.poses[2].isApprox(camera_pose(2), 1e-9));
  const KittiCalibration calib = read_kitti_calib_tr((d / "sequences/07/calib.txt").string());
  REQUIRE(calib.ok);
  const Eigen::Isometry3d& Tr = calib.T_cam_velo;
  CHECK(Tr.isApprox(kitti_like_tr(), 1e-9));
  const auto lidar = kitti_camera_to_lidar(poses.poses, Tr);
  // T_world_velo = Tr^-1 * P * Tr: the first pose is the identity and the car drives along lidar +x.
  CHECK(lidar[0].isApprox(Eigen::Isometry3d::Identity(), 1e-9));
  CHECK(lidar[1].translation().x() == Approx(0.9).margin(0.01));  // plus the lever arm of Tr under rotation
  CHECK(lidar[1].translation().y() == Approx(-0.1).margin(0.02));
  const KittiTimes times = read_kitti_times((d / "sequences/07/times.txt").string());
  REQUIRE(times.ok);
  CHECK(times.seconds.size() == 3);
  const TrajectoryFile lidar_poses = read_kitti_lidar_poses((d / "poses/07.txt").string(), (d / "sequences/07/calib.txt").string());
  REQUIRE(lidar_poses.ok);
  REQUIRE(lidar_poses.poses.size() == 3);
  CHECK(lidar_poses.poses[1].isApprox(lidar[1], 1e-12));

  // Malformed files: the message names the file and the line.
  write_text(d / "bad_poses.txt", pose_line(camera_pose(0)) + "1 0 0 0 0 1 0 0 0 0 1\n");
  const TrajectoryFile bad_poses = read_trajectory((d / "bad_poses.txt").string(), TrajectoryFormat::kKitti);
  CHECK_FALSE(bad_poses.ok);
  CHECK(bad_poses.error.find("bad_poses.txt:2:") != std::string::npos);
  CHECK(bad_poses.error.find("got 11") != std::string::npos);
  write_text(d / "bad_times.txt", "0.0\n0.1\nabc\n");
  const KittiTimes bad_times = read_kitti_times((d / "bad_times.txt").string());
  CHECK_FALSE(bad_times.ok);
  CHECK(bad_times.error.find("bad_times.txt:3:") != std::string::npos);
  write_text(d / "no_tr.txt", "P0: 1 2 3\n");
  const KittiCalibration no_tr = read_kitti_calib_tr((d / "no_tr.txt").string());
  CHECK_FALSE(no_tr.ok);
  CHECK(no_tr.error.find("Tr:") != std::string::npos);
  CHECK_FALSE(read_trajectory((d / "missing.txt").string(), TrajectoryFormat::kKitti).ok);
  CHECK_FALSE(read_kitti_lidar_poses((d / "missing.txt").string(), (d / "sequences/07/calib.txt").string()).ok);
  fs::remove_all(d);
}

#ifdef LOOPD_EVAL_TEST_HAS_LCM
namespace {
struct DecodedDrive {
  std::vector<std::string> channels;
  std::vector<StampedPose> gt, odom;
  std::vector<PointCloud> scans;
  std::vector<std::int64_t> scan_utimes;
};
DecodedDrive decode_drive(const std::string& path) {
  DecodedDrive d;
  LogReader r;
  std::string err;
  REQUIRE(r.open(path, &err));
  LogEvent ev;
  while (r.next(&ev)) {
    d.channels.push_back(ev.channel);
    if (ev.channel == channels::kScan) {
      point_cloud_t m;
      REQUIRE(LogReader::decode(ev, &m));
      PointCloud c;
      REQUIRE(from_message(m, &c, &err));
      d.scans.push_back(c);
      d.scan_utimes.push_back(m.utime);
    } else {
      pose_t m;
      REQUIRE(LogReader::decode(ev, &m));
      StampedPose p;
      REQUIRE(from_message(m, &p, &err));
      (ev.channel == channels::kGroundTruth ? d.gt : d.odom).push_back(p);
    }
  }
  return d;
}
int run(const std::string& cmd) { return std::system((cmd + " > /dev/null 2>&1").c_str()); }
}  // namespace

TEST_CASE("kitti2lcm round-trips a synthetic KITTI-format folder") {
  const std::string bin = bin_dir();
  if (!fs::exists(bin)) {
    WARN("skipped: " << bin << " not built (cmake --build <dir> --target kitti2lcm)");
    return;
  }
  const fs::path d = temp_dir("kitti2lcm");
  write_synthetic_kitti(d);
  const std::string seq = (d / "sequences/07").string(), poses = (d / "poses/07.txt").string();
  const std::string out = (d / "07.lcmlog").string();

  SECTION("odometry from a file equal to ground truth") {
    REQUIRE(run(bin + " --quiet --sequence " + seq + " --poses " + poses + " --odometry " + poses + " --out " + out) == 0);
    const DecodedDrive dr = decode_drive(out);
    REQUIRE(dr.channels.size() == 9);
    CHECK(dr.channels[0] == channels::kGroundTruth);
    CHECK(dr.channels[1] == channels::kPose);
    CHECK(dr.channels[2] == channels::kScan);
    REQUIRE(dr.scans.size() == 3);
    REQUIRE(dr.gt.size() == 3);
    const Eigen::Isometry3d Tr = kitti_like_tr();
    for (int i = 0; i < 3; ++i) {
      const auto u = static_cast<std::size_t>(i);
      const Eigen::Isometry3d expected = Tr.inverse() * camera_pose(i) * Tr;
      CHECK(dr.gt[u].T_world_sensor.isApprox(expected, 1e-6));
      CHECK(dr.odom[u].T_world_sensor.isApprox(expected, 1e-6));
      CHECK(dr.scans[u].size() == static_cast<std::size_t>(5 + i));
      CHECK(dr.scans[u].points[3].x() == 3.0f);
      CHECK(dr.scans[u].points[3].y() == -2.0f + static_cast<float>(i));
      CHECK(dr.scans[u].intensity[4] == Approx(0.4f));
      CHECK_FALSE(dr.scans[u].has_time());  // KITTI .bin scans have no per-point times: num_point_times = 0
      CHECK(dr.gt[u].utime == dr.scan_utimes[u]);
    }
    // utime = 1 s offset + times.txt
    CHECK(dr.scan_utimes[0] == 1000000);
    CHECK(dr.scan_utimes[1] == 1103615);
    CHECK(dr.scan_utimes[2] == 1207277);
  }
  SECTION("odometry with injected drift: deterministic, starts at ground truth, then differs") {
    const std::string out2 = (d / "07b.lcmlog").string();
    const std::string args = " --quiet --sequence " + seq + " --poses " + poses + " --drift-seed 5 --heading-bias 1.0 ";
    REQUIRE(run(bin + args + "--out " + out) == 0);
    REQUIRE(run(bin + args + "--out " + out2) == 0);
    const DecodedDrive a = decode_drive(out), b = decode_drive(out2);
    REQUIRE(a.odom.size() == 3);
    CHECK(a.odom[0].T_world_sensor.isApprox(a.gt[0].T_world_sensor, 1e-9));
    CHECK((a.odom[2].T_world_sensor.translation() - a.gt[2].T_world_sensor.translation()).norm() > 1e-3);
    CHECK(a.odom[2].residual > 0.0);
    CHECK(a.odom[2].T_world_sensor.isApprox(b.odom[2].T_world_sensor, 1e-12));
  }
  SECTION("--first-frame: the rest of the drive as a drive of its own, its scans, poses and times from that frame on") {
    REQUIRE(run(bin + " --quiet --sequence " + seq + " --poses " + poses + " --first-frame 1 --utime-offset 86401000000 --out " + out) == 0);
    const DecodedDrive dr = decode_drive(out);
    REQUIRE(dr.scans.size() == 2);
    REQUIRE(dr.gt.size() == 2);
    const Eigen::Isometry3d Tr = kitti_like_tr();
    for (int i = 0; i < 2; ++i) {
      const auto u = static_cast<std::size_t>(i);
      CHECK(dr.gt[u].T_world_sensor.isApprox(Tr.inverse() * camera_pose(i + 1) * Tr, 1e-6));
      CHECK(dr.scans[u].size() == static_cast<std::size_t>(6 + i));  // frame 1's scan has 6 points
    }
    CHECK(dr.odom[0].T_world_sensor.isApprox(dr.gt[0].T_world_sensor, 1e-9));  // its odometry starts at its ground truth
    CHECK(dr.scan_utimes[0] == 86401103615);                                   // a day later, frame 1's time
    CHECK(run(bin + " --quiet --sequence " + seq + " --poses " + poses + " --first-frame 3 --out " + out) != 0);  // past the last
  }
  SECTION("clear errors: missing scan, malformed poses, missing calibration, --max-frames") {
    fs::remove(d / "sequences/07/velodyne/000001.bin");
    const std::string err_file = (d / "err.txt").string();
    const std::string base = bin + " --quiet --sequence " + seq + " --out " + out;
    CHECK(std::system((base + " --poses " + poses + " > /dev/null 2> " + err_file).c_str()) != 0);
    std::ifstream e1(err_file);
    std::string msg((std::istreambuf_iterator<char>(e1)), {});
    CHECK(msg.find("000001.bin not found") != std::string::npos);
    CHECK(run(base + " --poses " + poses + " --skip-missing-scans") == 0);
    CHECK(decode_drive(out).scans.size() == 2);
    CHECK(run(base + " --poses " + poses + " --max-frames 1") == 0);
    CHECK(decode_drive(out).channels.size() == 3);

    write_text(d / "bad.txt", pose_line(camera_pose(0)) + "0 0 x 0 0 0 0 0 0 0 0 0\n");
    CHECK(std::system((base + " --poses " + (d / "bad.txt").string() + " > /dev/null 2> " + err_file).c_str()) != 0);
    std::ifstream e2(err_file);
    msg.assign((std::istreambuf_iterator<char>(e2)), {});
    CHECK(msg.find("bad.txt:2: 'x' is not a number") != std::string::npos);
    fs::remove(d / "sequences/07/calib.txt");
    CHECK(run(base + " --poses " + poses) != 0);
  }
  fs::remove_all(d);
}

TEST_CASE("kitti2lcm on the real KITTI 00 scans (skips without ../shared/data)") {
  LOOPD_REQUIRE_DATA(scan0, "kitti/seq00/000000.bin");
  LOOPD_REQUIRE_DATA(poses, "kitti/poses/00.txt");
  LOOPD_REQUIRE_DATA(times, "kitti/times/00.txt");
  LOOPD_REQUIRE_DATA(calib, "kitti/calib/Tr_velo_to_cam_00-02.txt");
  const std::string bin = bin_dir();
  if (!fs::exists(bin)) {
    WARN("skipped: " << bin << " not built");
    return;
  }
  const fs::path d = temp_dir("kitti2lcm_real");
  const std::string out = (d / "00.lcmlog").string();
  const std::string seq = fs::path(scan0).parent_path().string();
  REQUIRE(run(bin + " --quiet --sequence " + seq + " --poses " + poses + " --times " + times + " --calib " + calib + " --max-frames 6 --out " +
              out) == 0);
  const DecodedDrive dr = decode_drive(out);
  REQUIRE(dr.scans.size() == 6);
  for (const auto& s : dr.scans) {
    CHECK(s.size() >= 115000);  // README: 121k-125k points per scan
    CHECK(s.size() <= 130000);
  }
  const CloudFile direct_read = read_kitti_bin(scan0);
  REQUIRE(direct_read.ok);
  const PointCloud& direct = direct_read.cloud;
  CHECK(dr.scans[0].size() == direct.size());
  CHECK(dr.scans[0].points[1000] == direct.points[1000]);
  // At the start of 00 the car drives forward (lidar +x) at about 0.86 m per frame, on flat ground.
  const Eigen::Vector3d step = dr.gt[5].T_world_sensor.translation() - dr.gt[4].T_world_sensor.translation();
  CHECK(step.norm() == Approx(0.86).margin(0.05));
  CHECK(dr.gt[5].T_world_sensor.translation().x() > 4.0);
  CHECK(std::abs(dr.gt[5].T_world_sensor.translation().z()) < 0.2);
  CHECK(dr.scan_utimes[1] - dr.scan_utimes[0] == Approx(103615).margin(200));

  // --sensor hdl64 fills approximate rings from the elevations: 64 rings, nearly all of them populated.
  REQUIRE(run(bin + " --quiet --sequence " + seq + " --poses " + poses + " --times " + times + " --calib " + calib +
              " --max-frames 1 --sensor hdl64 --out " + out) == 0);
  const DecodedDrive ringed = decode_drive(out);
  REQUIRE(ringed.scans.size() == 1);
  REQUIRE(ringed.scans[0].has_rings());
  CHECK(ringed.scans[0].num_rings == 64);
  std::vector<int> per_ring(64, 0);
  for (auto r : ringed.scans[0].ring) ++per_ring[std::min<std::size_t>(r, 63)];
  CHECK(std::count_if(per_ring.begin(), per_ring.end(), [](int n) { return n > 200; }) >= 60);

  // Sparse folder: frames without a scan keep their poses with --skip-missing-scans (11 scans among 200 frames).
  REQUIRE(run(bin + " --quiet --sequence " + seq + " --poses " + poses + " --times " + times + " --calib " + calib +
              " --max-frames 200 --skip-missing-scans --out " + out) == 0);
  const DecodedDrive sparse = decode_drive(out);
  CHECK(sparse.gt.size() == 200);
  CHECK(sparse.scans.size() == 11);
  fs::remove_all(d);
}
#else
TEST_CASE("kitti2lcm (skipped: test not linked to loopd_lcm)") { WARN("skipped: no LCM headers"); }
#endif
