// Trajectory, KITTI (poses, times, calib), loop and residual text files given damaged or hostile content: each read
// fails with "<file>:<line>: <reason>" (no crash, no undefined behaviour on huge numbers), and good files still read.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "loopd/core/trajectory_io.hpp"
#include "loopd/correction/trajectory_io.hpp"

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
  std::string error;
  std::vector<Eigen::Isometry3d> poses;
  const std::string good = tmp.write("poses.txt", kIdentity + "1 0 0 2.5 0 1 0 0 0 0 1 -1\n");
  REQUIRE(read_kitti_poses(good, &poses, &error));
  REQUIRE(poses.size() == 2);
  CHECK(poses[1].translation().x() == 2.5);

  // 1e300 in the rotation overflows R^T R to inf/NaN: rejected (it used to pass the NaN comparison).
  std::string p = tmp.write("huge.txt", kIdentity + "1e300 0 0 0 0 1e300 0 0 0 0 1e300 0\n");
  CHECK_FALSE(read_kitti_poses(p, &poses, &error));
  CHECK(error.find(p + ":2: rotation part is not a rotation matrix") != std::string::npos);
  p = tmp.write("zero.txt", "0 0 0 0 0 0 0 0 0 0 0 0\n");
  CHECK_FALSE(read_kitti_poses(p, &poses, &error));
  CHECK(error.find(p + ":1: rotation part") != std::string::npos);
  p = tmp.write("short.txt", kIdentity + "1 0 0\n");
  CHECK_FALSE(read_kitti_poses(p, &poses, &error));
  CHECK(error.find(p + ":2: expected 12 numbers (3x4 pose), got 3") != std::string::npos);
  p = tmp.write("nul.txt", kIdentity + std::string("1 0 0 0 0 1 0 0 0 0 1 0\0junk\n", 30));
  CHECK_FALSE(read_kitti_poses(p, &poses, &error));
  CHECK(error.find(p + ":2: not a number") != std::string::npos);
  CHECK_FALSE(read_kitti_poses(tmp.dir.string(), &poses, &error));
  CHECK(error.find(tmp.dir.string() + ": is a directory") != std::string::npos);
  p = tmp.write("empty.txt", "");
  CHECK_FALSE(read_kitti_poses(p, &poses, &error));
  CHECK(error.find("holds no poses") != std::string::npos);

  std::vector<double> times;
  REQUIRE(read_kitti_times(tmp.write("times.txt", "0\n0.1\n0.2\n"), &times, &error));
  CHECK(times.size() == 3);
  p = tmp.write("times_huge.txt", "0\n1e300\n");
  CHECK_FALSE(read_kitti_times(p, &times, &error));
  CHECK(error.find(p + ":2: time") != std::string::npos);
  p = tmp.write("times_nan.txt", "0\nnan\n");
  CHECK_FALSE(read_kitti_times(p, &times, &error));
  CHECK(error.find(p + ":2: not a number: 'nan'") != std::string::npos);

  Eigen::Isometry3d Tr;
  p = tmp.write("calib.txt", "P0: 1 2 3\nTr: 2 0 0 0 0 2 0 0 0 0 2 0\n");
  CHECK_FALSE(read_kitti_calib_tr(p, &Tr, &error));
  CHECK(error.find(p + ":2: Tr: rotation part is not a rotation matrix") != std::string::npos);
  REQUIRE(read_kitti_calib_tr(tmp.write("calib_ok.txt", "P0: 1 2 3\nTr: " + kIdentity), &Tr, &error));
  CHECK(Tr.matrix().isIdentity());
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
  REQUIRE(loops.error.empty());
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
