// The 3D map end to end: loopd-sim drives the block (VLP-16, cars that move between laps), loopd replays it into a
// map file, loopd-map builds the map from the stored keyframe clouds (corrected, odometry, and without any cleaning),
// writes the octree and a picture, and loopd-eval measures each map against the drive's own scans at ground truth.
#include <catch2/catch.hpp>

#include <fstream>
#include <nlohmann/json.hpp>

#include "loopd/io/cloud_writer.hpp"
#include "support/run_command.hpp"
#include "support/temp_dir.hpp"

using namespace loopd;

namespace {

const std::string kBin = LOOPD_BINARY_DIR;

nlohmann::json run_json(const std::string& command) {
  int rc = 0;
  const std::string log = test::run_command(command, &rc);
  INFO(command << "\n" << log);
  REQUIRE(rc == 0);
  return nlohmann::json::parse(test::last_line(log));
}

std::string head_of(const std::string& path, std::size_t n) {
  std::ifstream f(path, std::ios::binary);
  std::string s(n, '\0');
  f.read(s.data(), static_cast<std::streamsize>(n));
  return s.substr(0, static_cast<std::size_t>(f.gcount()));
}

}  // namespace

TEST_CASE("3D map: the corrected map is nearer ground truth than the odometry map, and cleaning removes moved cars", "[e2e][map]") {
  test::TempDir dir("loopd_test_map_export");
  const std::string drive = dir.file("drive.lcmlog"), out = dir.file("out.lcmlog"), map = dir.file("map.db"), movers = dir.file("movers.json");
  int rc = 0;
  // 340 block scans (seed 23): a lap and a revisit; the movable cars change between the laps.
  std::string log = test::run_command(
      kBin + "/tools/loopd-sim/loopd-sim --route block --sensor vlp16 --scans 340 --seed 23 --quiet --out " + drive + " --movers-out " + movers, &rc);
  INFO(log);
  REQUIRE(rc == 0);
  log = test::run_command(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive + " --output " + out + " --map " + map, &rc);
  INFO(log);
  REQUIRE(rc == 0);

  const std::string loopd_store = kBin + "/tools/loopd-map/loopd-map " + map;
  const nlohmann::json corrected = run_json(loopd_store + " export-cloud --json --out " + dir.file("map.pcd"));
  CHECK(corrected["keyframes"].get<int>() > 100);
  CHECK(corrected["keyframes_without_cloud"].get<int>() == 0);
  CHECK(corrected["points"].get<int>() > 50000);
  CHECK(corrected["points_cleared"].get<int>() > 0);
  CHECK(corrected["correction_revision"].get<int>() > 0);
  run_json(loopd_store + " export-cloud --json --odometry --out " + dir.file("odometry.ply"));
  run_json(loopd_store + " export-cloud --json --keep-moving --keep-roadway-noise --keep-outliers --out " + dir.file("raw.pcd"));

  const std::string eval = kBin + "/tools/loopd-eval/loopd-eval --json --quiet --drive " + drive + " --results " + out + " --movers " + movers +
                           " --map-cloud-odometry " + dir.file("odometry.ply") + " --map-cloud ";
  const nlohmann::json cleaned = run_json(eval + dir.file("map.pcd"));
  const nlohmann::json raw = run_json(eval + dir.file("raw.pcd"));
  INFO("map error: corrected " << cleaned["map_error_m"] << ", odometry " << cleaned["map_error_odometry_m"] << "; moving share: cleaned "
                               << cleaned["map_moving_points_share"] << ", raw " << raw["map_moving_points_share"] << "; reference "
                               << cleaned["reference_moving_points"]);
  CHECK(cleaned["map_error_m"].get<double>() < 0.8 * cleaned["map_error_odometry_m"].get<double>());
  CHECK(cleaned["reference_moving_points"].get<int>() > 0);
  CHECK(cleaned["map_moving_points"].get<int>() < raw["map_moving_points"].get<int>());
  CHECK(cleaned["map_completeness"].get<double>() > 0.9 * raw["map_completeness"].get<double>());  // little static lost

  // The octree file at 0.5 m leaves (the map above used the default 0.2 m): what this checks is that a valid tree is
  // written, and at 0.2 m the ray casting took 15 of the test's 66 s again.
  const nlohmann::json octomap = run_json(loopd_store + " export-octomap --json --resolution 0.5 --out " + dir.file("map.bt"));
  CHECK(octomap["octree_leaves"].get<int>() > 10000);
  CHECK(head_of(dir.file("map.bt"), 28) == "# Octomap OcTree binary file");
  const nlohmann::json picture = run_json(loopd_store + " picture --json --out " + dir.file("map.png") + " --cloud " + dir.file("map.pcd"));
  CHECK(picture["loops"].get<int>() > 0);
  CHECK(head_of(dir.file("map.png"), 4) == "\x89PNG");

  // Bad requests: a clear error, exit status 2, nothing half-written.
  log = test::run_command(loopd_store + " export-cloud --out " + dir.file("map.xyz"), &rc);
  CHECK(rc == 2);
  CHECK(log.find("map.xyz") != std::string::npos);
  log = test::run_command(loopd_store + " export-cloud --session 7 --out " + dir.file("none.pcd"), &rc);
  CHECK(rc == 2);
  CHECK(log.find("no keyframes of session 7") != std::string::npos);
  PointCloud stray;
  stray.points = {{0.f, 0.f, 0.f}, {5e6f, 0.f, 0.f}};
  REQUIRE_FALSE(write_cloud_file(dir.file("stray.pcd"), stray).has_value());
  log = test::run_command(loopd_store + " picture --out " + dir.file("stray.png") + " --cloud " + dir.file("stray.pcd"), &rc);
  CHECK(rc == 2);
  CHECK(log.find("spans more than 1000 km") != std::string::npos);
}
