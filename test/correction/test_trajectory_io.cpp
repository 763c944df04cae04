// Text formats of loopd-correct (KITTI / TUM trajectories, loops, residuals) and the tool itself on a synthetic drive.
#include <catch2/catch.hpp>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "loopd/base/trajectory_io.hpp"
#include "loopd/correction/loop_file.hpp"
#include "loopd/correction/trajectory_tools.hpp"

using namespace loopd;
namespace fs = std::filesystem;

TEST_CASE("trajectory files: KITTI and TUM round trip") {
  const auto gt = make_lap_trajectory(50);
  const fs::path dir = fs::temp_directory_path() / "loopd_test_trajectory_io";
  fs::create_directories(dir);
  for (auto format : {TrajectoryFormat::kKitti, TrajectoryFormat::kTum}) {
    const std::string path = (dir / (format == TrajectoryFormat::kKitti ? "a.txt" : "a.tum")).string();
    std::vector<double> stamps;
    for (int i = 0; i < 50; ++i) stamps.push_back(1.5 + 0.1 * i);
    REQUIRE_FALSE(write_trajectory(path, gt, stamps, format));
    const TrajectoryFile f = read_trajectory(path, format);
    REQUIRE(f.error.empty());
    REQUIRE(f.poses.size() == gt.size());
    for (std::size_t i = 0; i < gt.size(); ++i) CHECK(f.poses[i].isApprox(gt[i], 1e-6));
    if (format == TrajectoryFormat::kTum) CHECK(f.stamps[10] == Approx(2.5));
  }
  fs::remove_all(dir);
}

TEST_CASE("trajectory files: malformed lines are reported with line number and reason") {
  std::istringstream bad_count("1 0 0 0 0 1 0 0 0 0 1 0\n# comment\n\n1 0 0 0 0 1 0 0 0 0 1\n");
  auto f = parse_trajectory(bad_count, TrajectoryFormat::kKitti, "poses.txt");
  CHECK(f.error == "poses.txt:4: expected 12 numbers (3x4 row-major pose), got 11");
  std::istringstream bad_number("1 0 0 0 0 1 0 x 0 0 1 0\n");
  CHECK(parse_trajectory(bad_number, TrajectoryFormat::kKitti, "p").error == "p:1: 'x' is not a number");
  std::istringstream bad_rotation("2 0 0 0 0 1 0 0 0 0 1 0\n");
  CHECK(parse_trajectory(bad_rotation, TrajectoryFormat::kKitti, "p").error.rfind("p:1: rotation part is not a rotation matrix", 0) == 0);
  std::istringstream bad_quat("0 1 2 3 0 0 0 0.5\n");
  CHECK(parse_trajectory(bad_quat, TrajectoryFormat::kTum, "t").error.rfind("t:1: quaternion is not unit length", 0) == 0);
  std::istringstream nan_value("0 1 2 nan 0 0 0 1\n");
  CHECK(parse_trajectory(nan_value, TrajectoryFormat::kTum, "t").error == "t:1: non-finite value 'nan'");
  std::istringstream empty("# nothing\n");
  CHECK(parse_trajectory(empty, TrajectoryFormat::kTum, "t").error == "t: no poses");

  std::istringstream loops("10 2 1 0 0 0 0 1 0 0 0 0 1 0\n10 2.5 1 0 0 0 0 1 0 0 0 0 1 0\n");
  CHECK(parse_loops(loops, "l").error == "l:2: match_index must be a non-negative integer");
  std::istringstream range("10 2 1 0 0 0 0 1 0 0 0 0 1 0\n");
  CHECK(parse_loops(range, "l", 5).error == "l:1: query_index 10 is out of range (trajectory has 5 poses)");
  std::istringstream short_loop("10 2 1 0 0\n");
  CHECK(parse_loops(short_loop, "l").error == "l:1: expected 14 numbers (query_index match_index + 12 of T_match_query), got 5");
  std::istringstream good("7 3 1 0 0 0.5 0 1 0 0 0 0 1 -2\n");
  const LoopFile lf = parse_loops(good, "l", 10);
  REQUIRE(lf.error.empty());
  REQUIRE(lf.loops.size() == 1);
  CHECK(lf.loops[0].query_index == 7);
  CHECK(lf.loops[0].match_index == 3);
  CHECK(lf.loops[0].T_match_query.translation().isApprox(Eigen::Vector3d(0.5, 0, -2)));

  std::istringstream residuals("0.1\n0.2 0.3\n");
  CHECK(parse_residuals(residuals, "r").error == "r:2: expected one residual, got 2 numbers");
  std::istringstream negative("0.1\n-1\n");
  CHECK(parse_residuals(negative, "r").error == "r:2: residual must be >= 0");
}

TEST_CASE("loopd-correct: corrects a drifted synthetic drive and reports malformed input") {
  const std::string tool = std::string(LOOPD_BINARY_DIR) + "/tools/loopd-correct/loopd-correct";
  if (!fs::exists(tool)) {
    WARN("skipped: " << tool << " not built");
    return;
  }
  const fs::path dir = fs::temp_directory_path() / "loopd_test_loopd_correct";
  fs::create_directories(dir);
  const auto gt = make_lap_trajectory(1500);
  const DriftedTrajectory odom = inject_drift(gt, {});
  const auto loops = find_ground_truth_loops(gt, 1.0, 100, 150, 0);
  REQUIRE(loops.size() >= 2);
  REQUIRE_FALSE(write_trajectory((dir / "odom.txt").string(), odom.poses, {}, TrajectoryFormat::kKitti));
  REQUIRE_FALSE(write_trajectory((dir / "gt.txt").string(), gt, {}, TrajectoryFormat::kKitti));
  {
    std::ofstream l(dir / "loops.txt");
    for (const auto& loop : loops) {
      l << loop.query_index << " " << loop.match_index;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) l << " " << loop.T_match_query.matrix()(r, c);
      l << "\n";
    }
    std::ofstream r(dir / "res.txt");
    for (double v : odom.residuals) r << v << "\n";
  }
  for (const char* method : {"heuristic", "graph", "heuristic+graph"}) {
    const std::string cmd = tool + " --odometry " + (dir / "odom.txt").string() + " --loops " + (dir / "loops.txt").string() + " --out " +
                            (dir / "out.txt").string() + " --residuals " + (dir / "res.txt").string() + " --method " + method + " --json > " +
                            (dir / "stdout.txt").string() + " 2>&1";
    REQUIRE(std::system(cmd.c_str()) == 0);
    const TrajectoryFile out = read_trajectory((dir / "out.txt").string(), TrajectoryFormat::kKitti);
    REQUIRE(out.error.empty());
    const TrajectoryError before = trajectory_error(odom.poses, gt), after = trajectory_error(out.poses, gt);
    INFO(method << ": mean " << before.mean_closest << " -> " << after.mean_closest);
    CHECK(before.mean_closest / after.mean_closest >= 2.0);
  }
  // A malformed loop file fails with its line number.
  {
    std::ofstream l(dir / "bad_loops.txt");
    l << "5 1 1 0 0 0 0 1 0 0 0 0 1 0\n5 1 1 0 0 0\n";
  }
  const std::string cmd = tool + " --odometry " + (dir / "odom.txt").string() + " --loops " + (dir / "bad_loops.txt").string() + " --out " +
                          (dir / "out2.txt").string() + " > " + (dir / "err.txt").string() + " 2>&1";
  CHECK(std::system(cmd.c_str()) != 0);
  std::ifstream err(dir / "err.txt");
  const std::string text((std::istreambuf_iterator<char>(err)), std::istreambuf_iterator<char>());
  CHECK(text.find("bad_loops.txt:2: expected 14 numbers") != std::string::npos);
  fs::remove_all(dir);
}
