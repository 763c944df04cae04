// loopd-spy starts lcm.spy.Spy on Java 17 with loopd_types.jar on its classpath (checked under a virtual X server).
#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <string>

TEST_CASE("loopd-spy starts under Xvfb and finds every loopd message type") {
  if (std::system("command -v xvfb-run >/dev/null 2>&1 && command -v java >/dev/null 2>&1") != 0) {
    WARN("skipped: xvfb-run or java not installed");
    return;
  }
  const std::string cmd = "cd " + std::string(LOOPD_SOURCE_DIR) + " && LOOPD_TYPES_JAR=" + std::string(LOOPD_BINARY_DIR) +
                          "/lcmtypes/loopd_types.jar timeout 12 xvfb-run -a scripts/loopd-spy --lcm-url 'udpm://239.255.76.67:7799?ttl=0' 2>&1";
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p);
  char buf[1024];
  while (fgets(buf, sizeof(buf), p)) out += buf;
  pclose(p);
  INFO(out);
  // One Java class per .lcm file in lcmtypes/.
  int types = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(LOOPD_SOURCE_DIR) + "/lcmtypes"))
    types += entry.path().extension() == ".lcm" ? 1 : 0;
  REQUIRE(types >= 10);  // localization_t was the tenth
  CHECK(out.find("Found " + std::to_string(types) + " LCM types") != std::string::npos);
  CHECK(out.find("Exception") == std::string::npos);
}
