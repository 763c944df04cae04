// The YAML config given malformed, hostile or odd input: an error that names the field or line, never an
// exception; the config is unchanged on failure; --print-config output loads back to the same values.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "loopd/runtime/daemon_config.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {
std::string load_error(const std::string& yaml) {
  DaemonConfig c;
  const DaemonConfig before = c;
  std::string error;
  CHECK_FALSE(load_config_text(yaml, &c, &error));
  CHECK(dump_config(c) == dump_config(before));  // unchanged on failure
  return error;
}
}  // namespace

TEST_CASE("config: malformed and hostile YAML give an error, never an exception", "[config]") {
  // Syntax errors carry yaml-cpp's line and column.
  CHECK(load_error("gate:\n  min_radius: [1, 2\n").find("YAML syntax") != std::string::npos);
  CHECK(load_error("a: b: c\n").find("line 1") != std::string::npos);
  // A map as a key used to throw out of the unknown-key walk.
  CHECK(load_error("? {a: 1}\n: 3\n").find("line 1") != std::string::npos);
  CHECK(load_error("gate:\n  ? [x]\n  : 3\n").find("gate: a key must be a plain name") != std::string::npos);
  // Non-finite numbers would pass "x <= 0" checks: refused with the field and line.
  CHECK(load_error("gate:\n  min_radius: .nan\n").find("line 2: gate.min_radius: expected a finite number, got '.nan'") != std::string::npos);
  CHECK(load_error("keyframe:\n  min_distance: .inf\n").find("keyframe.min_distance: expected a finite number") != std::string::npos);
  CHECK(load_error("threads: 99999999999999999999\n").find("line 1: threads: expected an integer") != std::string::npos);
  CHECK(load_error("threads: [1, 2]\n").find("threads: expected an integer, got 'a map or list'") != std::string::npos);
  CHECK(load_error("gate: 5\n").find("gate: unknown configuration key") != std::string::npos);
  CHECK(load_error("- 1\n- 2\n").find("must be a YAML map") != std::string::npos);
  CHECK_FALSE(load_error("\x01\x02\xff\xfe binary junk \x00").empty());
  // Deep nesting: yaml-cpp's parser limits it (DeepRecursion); the error comes back as text.
  CHECK_FALSE(load_error(std::string(100000, '[')).empty());
  CHECK_FALSE(load_error("gate: " + std::string(5000, '{')).empty());
  // Aliases that would expand a billion times stay references.
  std::string laughs = "a: &a [x, x, x, x, x, x, x, x, x, x]\n";
  for (char c = 'b'; c <= 'j'; ++c) {
    const std::string prev = "*" + std::string(1, static_cast<char>(c - 1));
    laughs += std::string(1, c) + ": &" + c + " [" + prev + ", " + prev + ", " + prev + ", " + prev + ", " + prev + ", " + prev + "]\n";
  }
  CHECK(load_error(laughs).find("unknown configuration key") != std::string::npos);
}

TEST_CASE("config files: directories, devices and oversized files are refused by name, dumps with odd strings load back", "[config]") {
  const fs::path dir = fs::temp_directory_path() / ("loopd_test_config_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  DaemonConfig c;
  std::string error;
  CHECK_FALSE(load_config(dir.string(), &c, &error));
  CHECK(error == "cannot read config file " + dir.string() + " (a directory)");
  CHECK_FALSE(load_config("/dev/zero", &c, &error));
  CHECK(error.find("/dev/zero (not a regular file)") != std::string::npos);
  const std::string big = (dir / "big.yaml").string();
  std::ofstream(big) << "# " << std::string(2 << 20, 'x') << "\n";
  CHECK_FALSE(load_config(big, &c, &error));
  CHECK(error.find(big + " is 2097155 bytes") != std::string::npos);
  const std::string bad = (dir / "bad.yaml").string();
  std::ofstream(bad) << "threads: 2\ngate:\n  min_radius: abc\n";
  CHECK_FALSE(load_config(bad, &c, &error));
  CHECK(error == bad + ": line 3: gate.min_radius: expected a number, got 'abc'");
  fs::remove_all(dir);

  // Strings with quotes, backslashes, colons and YAML syntax used to break --print-config (the dump was re-parsed
  // as YAML text).
  DaemonConfig odd;
  REQUIRE(load_config_text("lcm_url: \"udpm://239.255.76.67:7667?ttl=0\"\nchannels:\n  scan: 'a \"quoted\" \\ [scan]: {x}'\n", &odd, &error));
  const std::string dumped = dump_config(odd);
  DaemonConfig back;
  REQUIRE(load_config_text(dumped, &back, &error));
  CHECK(back.node.scan_channel == "a \"quoted\" \\ [scan]: {x}");
  CHECK(back.node.lcm_url == "udpm://239.255.76.67:7667?ttl=0");
  CHECK(dump_config(back) == dumped);
}
