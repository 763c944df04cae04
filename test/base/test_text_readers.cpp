// Trajectory, KITTI (poses, times, calib), loop and residual text files given damaged or hostile content: each read
// fails with "<file>:<line>: <reason>" (no crash, no undefined behaviour on huge numbers), and good files still read.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "loopd/base/trajectory_io.hpp"
#include "loopd/correction/loop_file.hpp"
#include "loopd/io/kitti_files.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {
struct TempDir {
  fs::path dir = fs::temp_directory_path() / ("loopd_test_text_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(dir); }
  ~TempDir() { fs::remove_all(dir); }
  std::string write(const std::string& name, const std::string& text) const {
    const std::string p = (dir / name).string();
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
};
const std::string kIdentity = "1 0 0 0 0 1 0 0 0 0 1 0\n";
}  // namespace

TEST_CASE("KITTI poses, times and calib: bad lines are named by file and line, good files read", "[io]") {
  TempDir tmp;
  const auto read_kitti = [](const std::string& path) { return read_trajectory(path, TrajectoryFormat::kKitti); };
  const std::string good = tmp.write("poses.txt", kIdentity + "1 0 0 2.5 0 1 0 0 0 0 1 -1\n");
  TrajectoryFile poses = read_kitti(good);
  REQUIRE(poses.ok);
  REQUIRE(poses.poses.size() == 2);
  CHECK(poses.poses[1].translation().x() == 2.5);

  // 1e300 in the rotation overflows R^T R to inf/NaN: rejected (it used to pass the NaN comparison).
  std::string p = tmp.write("huge.txt", kIdentity + "1e300 0 0 0 0 1e300 0 0 0 0 1e300 0\n");
  poses = read_kitti(p);
  CHECK_FALSE(poses.ok);
  CHECK(poses.error.find(p + ":2: rotation part is not a rotation matrix") != std::string::npos);
  p = tmp.write("zero.txt", "0 0 0 0 0 0 0 0 0 0 0 0\n");
  poses = read_kitti(p);
  CHECK_FALSE(poses.ok);
  CHECK(poses.error.find(p + ":1: rotation part") != std::string::npos);
  p = tmp.write("short.txt", kIdentity + "1 0 0\n");
  poses = read_kitti(p);
  CHECK_FALSE(poses.ok);
  CHECK(poses.error.find(p + ":2: expected 12 numbers (3x4 row-major pose), got 3") != std::string::npos);
  p = tmp.write("nul.txt", kIdentity + std::string("1 0 0 0 0 1 0 0 0 0 1 0\0junk\n", 30));
  poses = read_kitti(p);
  CHECK_FALSE(poses.ok);
  CHECK(poses.error.find(p + ":2: '0") != std::string::npos);
  CHECK(poses.error.find("' is not a number") != std::string::npos);
  poses = read_kitti(tmp.dir.string());
  CHECK_FALSE(poses.ok);
  CHECK(poses.error.find(tmp.dir.string() + ": is a directory") != std::string::npos);
  p = tmp.write("empty.txt", "");
  poses = read_kitti(p);
  CHECK_FALSE(poses.ok);
  CHECK(poses.error == p + ": no poses");

  KittiTimes times = read_kitti_times(tmp.write("times.txt", "0\n0.1\n0.2\n"));
  REQUIRE(times.ok);
  CHECK(times.seconds.size() == 3);
  p = tmp.write("times_huge.txt", "0\n1e300\n");
  times = read_kitti_times(p);
  CHECK_FALSE(times.ok);
  CHECK(times.error.find(p + ":2: time") != std::string::npos);
  p = tmp.write("times_nan.txt", "0\nnan\n");
  times = read_kitti_times(p);
  CHECK_FALSE(times.ok);
  CHECK(times.error.find(p + ":2: non-finite value 'nan'") != std::string::npos);

  p = tmp.write("calib.txt", "P0: 1 2 3\nTr: 2 0 0 0 0 2 0 0 0 0 2 0\n");
  KittiCalibration calib = read_kitti_calib_tr(p);
  CHECK_FALSE(calib.ok);
  CHECK(calib.error.find(p + ":2: Tr: rotation part is not a rotation matrix") != std::string::npos);
  calib = read_kitti_calib_tr(tmp.write("calib_ok.txt", "P0: 1 2 3\nTr: " + kIdentity));
  REQUIRE(calib.ok);
  CHECK(calib.T_cam_velo.matrix().isIdentity());
}

TEST_CASE("KITTI poses and times: one rule set with the other text files (blank and '#' lines skipped)", "[io]") {
  TempDir tmp;
  // A comment and blank lines between poses: skipped, the pose index counts poses (stamps 0, 1), not lines.
  const std::string p = tmp.write("poses.txt", "# KITTI poses\n" + kIdentity + "\n  \n1 0 0 2.5 0 1 0 0 0 0 1 -1\n\n");
  const TrajectoryFile poses = read_trajectory(p, TrajectoryFormat::kKitti);
  REQUIRE(poses.ok);
  REQUIRE(poses.poses.size() == 2);
  CHECK(poses.poses[1].translation().x() == 2.5);
  CHECK(poses.stamps == std::vector<double>{0.0, 1.0});
  // A rotation off by 1e-3 (within the 1e-2 tolerance) is re-orthonormalised; one off by 0.1 is refused with file:line.
  const TrajectoryFile near = read_trajectory(tmp.write("near.txt", "1.001 0 0 0 0 1 0 0 0 0 1 0\n"), TrajectoryFormat::kKitti);
  REQUIRE(near.ok);
  CHECK((near.poses[0].linear().transpose() * near.poses[0].linear()).isIdentity(1e-12));
  const std::string far = tmp.write("far.txt", kIdentity + "1.1 0 0 0 0 1 0 0 0 0 1 0\n");
  CHECK(read_trajectory(far, TrajectoryFormat::kKitti).error.rfind(far + ":2: rotation part is not a rotation matrix", 0) == 0);
  const KittiTimes times = read_kitti_times(tmp.write("times.txt", "# s\n0\n\n0.1\n"));
  REQUIRE(times.ok);
  CHECK(times.seconds == std::vector<double>{0.0, 0.1});
  const std::string empty = tmp.write("times_empty.txt", "# nothing\n");
  CHECK(read_kitti_times(empty).error == empty + ": no times");
}

TEST_CASE("trajectory, loop and residual files: huge indices and values are errors with file and line", "[io]") {
  TempDir tmp;
  // An index of 1e300 used to reach a double -> long cast (undefined behaviour) when formatting the error.
  std::string p = tmp.write("loops.txt", "# q m T\n1e300 0 " + kIdentity);
  LoopFile loops = read_loops(p, 10);
  CHECK(loops.error.find(p + ":2: query_index") != std::string::npos);
  CHECK(loops.error.find("out of range") != std::string::npos);
  loops = read_loops(p, -1);
  CHECK(loops.error.find(p + ":2: query_index") != std::string::npos);
  p = tmp.write("loops_ok.txt", "5 1 " + kIdentity);
  loops = read_loops(p, 10);
  REQUIRE(loops.ok);
  REQUIRE(loops.loops.size() == 1);
  CHECK(loops.loops[0].query_index == 5);
  CHECK(read_loops(tmp.dir.string(), 10).error.find("is a directory") != std::string::npos);

  p = tmp.write("tum.txt", "0 1 2 3 0 0 0 1\n1 1e308 1e308 1e308 1e200 1e200 0 1\n");
  TrajectoryFile t = read_trajectory(p, TrajectoryFormat::kTum);
  CHECK(t.error.find(p + ":2: quaternion is not unit length") != std::string::npos);
  p = tmp.write("kitti.txt", kIdentity + "1e300 1e300 1e300 0 1e300 1e300 1e300 0 1e300 1e300 1e300 0\n");
  t = read_trajectory(p, TrajectoryFormat::kKitti);
  CHECK(t.error.find(p + ":2: rotation part is not a rotation matrix") != std::string::npos);
  ResidualFile r = read_residuals(tmp.write("res.txt", "0.1\n-0.5\n"));
  CHECK(r.error.find(":2: residual must be >= 0") != std::string::npos);
}
