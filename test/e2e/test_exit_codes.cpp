// The exit status table every loopd program follows (tools/common/exit_codes.hpp, docs/tools.md): 0 done, 1 it ran
// and found a problem, 2 bad input or usage. Each program is run with --help, an unknown option, and an input that
// does not exist (or an output that cannot be opened).
#include <catch2/catch.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "support/run_command.hpp"

namespace {

const std::string kBin = LOOPD_BINARY_DIR;
const std::string kMissing = "/nonexistent/loopd-exit-codes/none";

struct Program {
  std::string path;       ///< relative to the build folder
  std::string bad_input;  ///< arguments naming an input that does not exist (or an output that cannot be opened)
};

const std::vector<Program>& programs() {
  static const std::vector<Program> all = {
      {"daemon/loopd", "--replay " + kMissing + ".lcmlog --output /tmp/loopd-exit-codes.lcmlog"},
      {"tools/loopd-sim/loopd-sim", "--scans 2 --out " + kMissing + ".lcmlog"},
      {"tools/loopd-eval/loopd-eval", "--drive " + kMissing + ".lcmlog --results " + kMissing + "-out.lcmlog"},
      {"tools/loopd-compare/loopd-compare", kMissing + "-a.lcmlog " + kMissing + "-b.lcmlog"},
      {"tools/loopd-map/loopd-map", kMissing + ".db info"},
      {"tools/loopd-register/loopd-register", kMissing + "-q.bin " + kMissing + "-m.bin"},
      {"tools/loopd-verify/loopd-verify", kMissing + "-q.bin " + kMissing + "-m.bin"},
      {"tools/loopd-describe/loopd-describe", kMissing + ".bin"},
      {"tools/loopd-correct/loopd-correct", "--odometry " + kMissing + ".txt --loops " + kMissing + "-loops.txt --out /tmp/loopd-exit-codes.txt"},
      {"tools/kitti2lcm/kitti2lcm", "--sequence " + kMissing + " --poses " + kMissing + ".txt --out /tmp/loopd-exit-codes.lcmlog"},
      {"tools/bag2lcm/bag2lcm", kMissing + ".bag --out /tmp/loopd-exit-codes.lcmlog --cloud-topic /points --odom-topic /odom"},
      {"tools/loopd-bench/loopd-bench", "m2dp --file " + kMissing + ".bin"},
  };
  return all;
}

int status_of(const std::string& command, std::string* output = nullptr) {
  int rc = -1;
  const std::string out = loopd::test::run_command(command + " < /dev/null", &rc);
  if (output) *output = out;
  return rc;
}

}  // namespace

TEST_CASE("every program exits 0 after --help, 2 on an unknown option, 2 on an input that does not exist") {
  int checked = 0;
  for (const Program& p : programs()) {
    const std::string bin = kBin + "/" + p.path;
    if (!std::filesystem::exists(bin)) {
      WARN(p.path << " is not built here (optional): not checked");
      continue;
    }
    ++checked;
    std::string out;
    INFO(p.path);
    CHECK(status_of(bin + " --help") == 0);
    const int unknown = status_of(bin + " --no-such-option", &out);
    INFO("unknown option: " << out);
    CHECK(unknown == 2);
    const int bad = status_of(bin + " " + p.bad_input, &out);
    INFO("bad input: " << out);
    CHECK(bad == 2);
    CHECK_FALSE(out.empty());  // and it says why
  }
  CHECK(checked >= 11);
}

TEST_CASE("a program given no arguments at all where it needs some exits 2, never CLI11's own codes") {
  for (const char* p :
       {"tools/loopd-eval/loopd-eval", "tools/loopd-correct/loopd-correct", "tools/kitti2lcm/kitti2lcm", "tools/loopd-register/loopd-register",
        "tools/loopd-bench/loopd-bench", "tools/loopd-compare/loopd-compare", "tools/loopd-map/loopd-map"}) {
    INFO(p);
    CHECK(status_of(kBin + "/" + p) == 2);
  }
  CHECK(status_of(kBin + "/tools/loopd-bench/loopd-bench no-such-benchmark") == 2);
}

TEST_CASE("loopd --http that cannot listen, or is not an address, exits 2 and says why") {
  std::string out;
  CHECK(status_of(kBin + "/daemon/loopd --http nope --replay x.lcmlog 2>&1", &out) == 2);
  CHECK(out.find("http.listen (--http): 'nope' is not PORT or IPV4:PORT") != std::string::npos);
  // An address this machine does not have (TEST-NET-3): refused before anything is read.
  const std::string drive = "/tmp/loopd-exit-codes-http.lcmlog";
  REQUIRE(status_of(kBin + "/tools/loopd-sim/loopd-sim --scans 3 --quiet --out " + drive) == 0);
  CHECK(status_of(kBin + "/daemon/loopd --http 203.0.113.254:9 --replay " + drive + " --output /tmp/loopd-exit-codes.lcmlog 2>&1", &out) == 2);
  CHECK(out.find("loopd: --http 203.0.113.254:9: cannot listen on 203.0.113.254:9") != std::string::npos);
  std::filesystem::remove(drive);
}
