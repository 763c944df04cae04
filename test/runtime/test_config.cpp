#include <catch2/catch.hpp>

#include <fstream>
#include <sstream>

#include "loopd/runtime/daemon_config.hpp"

using namespace loopd;

TEST_CASE("the defaults are valid and survive a dump/load round trip") {
  DaemonConfig c;
  std::string error;
  REQUIRE(load_config_text("", &c, &error));
  const std::string yaml = dump_config(c);
  DaemonConfig back;
  REQUIRE(load_config_text(yaml, &back, &error));
  CHECK(dump_config(back) == yaml);
  CHECK(yaml.find("min_radius") != std::string::npos);
}

TEST_CASE("a wrong value is refused with the field's name") {
  DaemonConfig c;
  std::string error;
  CHECK_FALSE(load_config_text("gate:\n  min_radius: abc\n", &c, &error));
  CHECK(error.find("gate.min_radius") != std::string::npos);
  error.clear();
  CHECK_FALSE(load_config_text("gate:\n  min_radius: -3\n", &c, &error));
  CHECK(error.find("gate.min_radius") != std::string::npos);
  error.clear();
  CHECK_FALSE(load_config_text("association:\n  tolerence: 0.1\n", &c, &error));
  CHECK(error.find("association.tolerence") != std::string::npos);
  error.clear();
  CHECK_FALSE(load_config_text("sensor: hdl99\n", &c, &error));
  CHECK(error.find("sensor") != std::string::npos);
  error.clear();
  CHECK_FALSE(load_config_text("map:\n  localize: true\n", &c, &error));  // nothing to localize in
  CHECK(error.find("map.localize (--localize) needs a map") != std::string::npos);
  error.clear();
  {  // localizing in a shared map is taken (read-only, one vehicle's sessions: test_multi_session)
    DaemonConfig shared;
    CHECK(load_config_text("map:\n  localize: true\n  path: postgresql://loopd@/fleet\n", &shared, &error));
    CHECK(shared.node.localize);
  }
  CHECK_FALSE(load_config_text("map:\n  ledger_poll: 0\n", &c, &error));
  CHECK(error.find("map.ledger_poll") != std::string::npos);
}

TEST_CASE("values are read into the config") {
  DaemonConfig c;
  std::string error;
  REQUIRE(load_config_text("sensor: vlp16\nchannels:\n  scan: MY_SCAN\nkeyframe:\n  min_distance: 3.5\nthreads: 2\n", &c, &error));
  CHECK(c.engine.detector.sensor == "vlp16");
  CHECK(c.node.scan_channel == "MY_SCAN");
  CHECK(c.engine.detector.keyframe.min_distance == 3.5);
  CHECK(c.engine.num_threads == 2);
}

TEST_CASE("the documented example config names every field and equals the defaults") {
  DaemonConfig from_file, defaults;
  std::string error;
  REQUIRE(load_config(std::string(LOOPD_SOURCE_DIR) + "/daemon/loopd.example.yaml", &from_file, &error));
  CHECK(dump_config(from_file) == dump_config(defaults));
  // Every field of the effective config appears in the example.
  std::ifstream in(std::string(LOOPD_SOURCE_DIR) + "/daemon/loopd.example.yaml");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string example = ss.str();
  std::stringstream dump(dump_config(defaults));
  std::string line;
  while (std::getline(dump, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(line.find_first_not_of(' '), colon - line.find_first_not_of(' '));
    CHECK(example.find(key + ":") != std::string::npos);
  }
}
