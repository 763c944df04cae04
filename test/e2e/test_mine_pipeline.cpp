// End to end in the simulated mine: loopd-sim drives the mine route (VLP-16), the loopd daemon replays it, loopd-eval
// judges the loops and the corrected trajectory against ground truth; the test reads the loop events itself too.
#include <catch2/catch.hpp>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <loopd/loop_event_t.hpp>

#include "lcm_log.hpp"
#include "support/run_command.hpp"
#include "message_convert.hpp"

using namespace loopd;
namespace fs = std::filesystem;

TEST_CASE("loopd closes loops in the simulated mine and rejects degenerate tunnel alignments", "[e2e][mine]") {
  const std::string bin = LOOPD_BINARY_DIR;
  const fs::path dir = fs::temp_directory_path() / ("loopd_mine_e2e_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string drive = (dir / "mine.lcmlog").string(), out = (dir / "out.lcmlog").string(), map = (dir / "map.db").string();
  int rc = 0;
  // 1000 scans at the mine's 5 m/s: the cell loop (~330 m), then the long loop's first roadways, revisited in the same
  // direction.
  std::string log =
      loopd::test::run_command(bin + "/tools/loopd-sim/loopd-sim --out " + drive + " --route mine --sensor vlp16 --scans 1000 --seed 1 --quiet", &rc);
  INFO(log);
  REQUIRE(rc == 0);
  log = loopd::test::run_command(bin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive + " --output " + out + " --map " + map, &rc);
  INFO(log);
  REQUIRE(rc == 0);

  LogReader reader;
  std::string error;
  REQUIRE(reader.open(out, &error));
  LogEvent ev;
  int accepted = 0, degenerate = 0, turned = 0;
  while (reader.next(&ev)) {
    if (ev.channel != channels::kLoopEvent) continue;
    loop_event_t e;
    REQUIRE(LogReader::decode(ev, &e));
    if (e.status == loop_event_t::STATUS_ACCEPTED) ++accepted;
    if (e.status == loop_event_t::STATUS_REJECTED && e.stage == "degeneracy") ++degenerate;
    if (e.status == loop_event_t::STATUS_REJECTED && e.stage == "prior") ++turned;
  }
  CHECK(accepted >= 1);
  CHECK(degenerate >= 1);  // tunnel candidates whose alignment slides along the roadway
  CHECK(turned >= 1);      // roadways and junctions that align turned by 90 or 180 deg against the map's prior

  log = loopd::test::run_command(bin + "/tools/loopd-eval/loopd-eval --json --quiet --drive " + drive + " --results " + out, &rc);
  INFO(log);
  REQUIRE(rc == 0);
  const nlohmann::json j = nlohmann::json::parse(loopd::test::last_line(log));
  CHECK(j["accepted"].get<int>() == accepted);
  CHECK(j["correct"].get<int>() >= 1);
  CHECK(j["ate_after"].get<double>() < j["ate_before"].get<double>());
  // Every accepted loop within loopd-eval's 0.5 m / 2 deg (the measured run: 40 of 40, recall 1.0).
  CHECK(j["correct"].get<int>() == j["accepted"].get<int>());

  // The mine's 3D map: most of the path is enclosed roadway, so Ren's section filter cuts tunnel sections there.
  log = loopd::test::run_command(bin + "/tools/loopd-map/loopd-map " + map + " export-cloud --json --out " + (dir / "mine.ply").string(), &rc);
  INFO(log);
  REQUIRE(rc == 0);
  const nlohmann::json m = nlohmann::json::parse(loopd::test::last_line(log));
  CHECK(m["points"].get<int>() > 50000);
  CHECK(m["tunnel_stations"].get<int>() > m["stations"].get<int>() / 4);
  fs::remove_all(dir);
}
