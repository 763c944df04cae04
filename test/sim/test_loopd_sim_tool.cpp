// loopd-sim tool: same seed -> byte-identical lcm-logger files (also across thread counts); --json summary; sensor
// effects on by default, and with every --no-* flag the scans of before them; --session 1 the drive of before sessions.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <unistd.h>

#include <loopd/point_cloud_t.hpp>

#include "lcm_log.hpp"

namespace {

namespace fs = std::filesystem;

std::string tool_path() { return std::string(LOOPD_BINARY_DIR) + "/tools/loopd-sim/loopd-sim"; }

/// Runs a command; returns its exit code and stdout.
int run(const std::string& cmd, std::string* out) {
  FILE* p = popen((cmd + " 2>/dev/null").c_str(), "r");
  if (!p) return -1;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) out->append(buf, n);
  return pclose(p);
}

std::string read_bytes(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

nlohmann::json last_json_line(const std::string& out) {
  const auto end = out.find_last_not_of('\n');
  const auto start = out.rfind('\n', end);
  return nlohmann::json::parse(out.substr(start == std::string::npos ? 0 : start + 1, end - (start == std::string::npos ? 0 : start + 1) + 1));
}

std::uint64_t fnv1a(std::uint64_t h, const std::uint8_t* p, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
  return h;
}

/// FNV-1a over a drive log's events (channel, then payload), each scan without its fingerprint and without the
/// num_point_times that today's layout appends (which must be 0): comparable with a log of the layout before per-point
/// times. Counts the scans in *scans.
std::uint64_t log_hash_without_times(const fs::path& path, int* scans) {
  loopd::LogReader reader;
  std::string error;
  REQUIRE(reader.open(path.string(), &error));
  loopd::LogEvent ev;
  std::uint64_t h = 0xcbf29ce484222325ull;
  *scans = 0;
  while (reader.next(&ev)) {
    h = fnv1a(h, reinterpret_cast<const std::uint8_t*>(ev.channel.data()), ev.channel.size());
    if (ev.channel == "LIDAR_SCAN") {
      REQUIRE(ev.data.size() > 12);
      REQUIRE(std::vector<std::uint8_t>(ev.data.end() - 4, ev.data.end()) == std::vector<std::uint8_t>(4, 0));  // num_point_times = 0
      h = fnv1a(h, ev.data.data() + 8, ev.data.size() - 12);
      ++*scans;
    } else {
      h = fnv1a(h, ev.data.data(), ev.data.size());
    }
  }
  return h;
}

}  // namespace

TEST_CASE("with every effect off loopd-sim writes the scans of the simulator before sensor effects, bit for bit", "[sim][tool][effects]") {
  if (!fs::exists(tool_path())) FAIL("build the loopd-sim target first: " << tool_path());
  const fs::path dir = fs::temp_directory_path() / ("loopd_sim_clean_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::string out;
  REQUIRE(run(tool_path() +
                  " --quiet --sensor vlp16 --scans 12 --seed 11 --route block --no-motion-skew --no-point-times --no-dropouts "
                  "--no-vegetation --out " +
                  (dir / "clean.lcmlog").string(),
              &out) == 0);
  int scans = 0;
  // The same hash over the log that loopd-sim wrote before sensor effects existed (commit 9422b0c; point_cloud_t
  // without num_point_times, whose scans hash the same bytes): scans, odometry and ground truth unchanged.
  CHECK(log_hash_without_times(dir / "clean.lcmlog", &scans) == 0x02973e0d224e3381ull);
  CHECK(scans == 12);
  fs::remove_all(dir);
}

TEST_CASE("loopd-sim's default scans carry per-point times over one sweep, the effects are documented and tunable", "[sim][tool][effects]") {
  if (!fs::exists(tool_path())) FAIL("build the loopd-sim target first: " << tool_path());
  const fs::path dir = fs::temp_directory_path() / ("loopd_sim_effects_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string base = tool_path() + " --quiet --sensor vlp16 --scans 3 --seed 4 --json --out ";
  std::string on, rate, help;
  REQUIRE(run(base + (dir / "on.lcmlog").string(), &on) == 0);
  REQUIRE(run(base + (dir / "rate.lcmlog").string() + " --dropout-rate 0.3", &rate) == 0);
  const auto j = last_json_line(on);
  CHECK(j.at("effects").at("motion_skew").get<bool>());
  CHECK(j.at("effects").at("vegetation").get<bool>());
  CHECK(j.at("effects").at("dropout_rate").get<double>() == Approx(0.03));
  CHECK(last_json_line(rate).at("points_per_scan_mean").get<double>() < 0.9 * j.at("points_per_scan_mean").get<double>());

  loopd::LogReader reader;
  std::string error;
  REQUIRE(reader.open((dir / "on.lcmlog").string(), &error));
  loopd::LogEvent ev;
  int scans = 0;
  while (reader.next(&ev)) {
    if (ev.channel != "LIDAR_SCAN") continue;
    loopd::point_cloud_t m;
    REQUIRE(loopd::LogReader::decode(ev, &m));
    REQUIRE(m.num_point_times == m.num_points);
    const auto [lo, hi] = std::minmax_element(m.time_offset.begin(), m.time_offset.end());
    CHECK(*hi == 0.0f);                         // stamped at the end of the sweep
    CHECK(*lo == Approx(-0.1).epsilon(0.001));  // 10 Hz: one sweep lasts 0.1 s
    ++scans;
  }
  CHECK(scans == 3);

  REQUIRE(run(tool_path() + " --help", &help) == 0);
  for (const char* flag : {"--no-motion-skew", "--no-point-times", "--no-dropouts", "--dropout-rate", "--no-vegetation", "--foliage-density"}) {
    CAPTURE(flag);
    CHECK(help.find(flag) != std::string::npos);
  }
  std::string dummy;
  CHECK(run(base + (dir / "bad.lcmlog").string() + " --dropout-rate 1.5", &dummy) != 0);
  fs::remove_all(dir);
}

TEST_CASE("loopd-sim writes byte-identical logs for the same seed", "[sim][tool]") {
  if (!fs::exists(tool_path())) FAIL("build the loopd-sim target first: " << tool_path());
  const fs::path dir = fs::temp_directory_path() / ("loopd_sim_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string base = tool_path() + " --quiet --sensor hdl64 --scans 3 --json --out ";
  std::string out1, out2, out3, out4;
  REQUIRE(run(base + (dir / "a.lcmlog").string() + " --seed 5 --threads 1", &out1) == 0);
  REQUIRE(run(base + (dir / "b.lcmlog").string() + " --seed 5 --threads 2", &out2) == 0);
  REQUIRE(run(base + (dir / "c.lcmlog").string() + " --seed 6 --threads 2", &out3) == 0);
  const std::string a = read_bytes(dir / "a.lcmlog"), b = read_bytes(dir / "b.lcmlog"), c = read_bytes(dir / "c.lcmlog");
  CHECK(a.size() > 3u * 100000u * 16u);  // 3 scans of >= 100k points (x, y, z, intensity floats)
  CHECK(a == b);
  CHECK(a != c);

  const auto j = last_json_line(out1);
  CHECK(j.at("scans").get<int>() == 3);
  CHECK(j.at("points_per_scan_mean").get<double>() > 100000.0);
  CHECK(j.at("points_per_scan_mean").get<double>() < 130000.0);
  CHECK(j.at("sensor").get<std::string>() == "hdl64");
  CHECK(j.contains("seconds"));

  REQUIRE(run(tool_path() + " --list-sensors --json", &out4) == 0);
  const auto s = last_json_line(out4);
  CHECK(s.at("sensors").size() >= 4u);
  std::string dummy;
  CHECK(run(tool_path() + " --sensor nope --out " + (dir / "x.lcmlog").string(), &dummy) != 0);
  fs::remove_all(dir);
}

TEST_CASE("loopd-sim --session 1 is today's drive bit for bit, --session and --odometry-reset-at are reported and checked", "[sim][tool][session]") {
  if (!fs::exists(tool_path())) FAIL("build the loopd-sim target first: " << tool_path());
  const fs::path dir = fs::temp_directory_path() / ("loopd_sim_session_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string base = tool_path() + " --quiet --route block --sensor vlp16 --scans 12 --seed 3 --json --out ";
  std::string plain, one, two, help;
  REQUIRE(run(base + (dir / "plain.lcmlog").string(), &plain) == 0);
  REQUIRE(run(base + (dir / "one.lcmlog").string() + " --session 1", &one) == 0);
  REQUIRE(run(base + (dir / "two.lcmlog").string() + " --session 2 --odometry-reset-at 4", &two) == 0);
  // FNV-1a of the whole log loopd-sim wrote for these options before sessions existed (commit 038b817), taken again
  // when the heading came to be interpolated between route samples.
  const std::string bytes = read_bytes(dir / "plain.lcmlog");
  CHECK(fnv1a(0xcbf29ce484222325ull, reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()) == 0x3a53ba02ffd513dcull);
  CHECK(read_bytes(dir / "one.lcmlog") == bytes);
  const auto j1 = last_json_line(one), j2 = last_json_line(two);
  CHECK(j1.at("session").get<int>() == 1);
  CHECK(j1.at("odometry_reset_at").is_null());
  CHECK(j1.at("start_offset_m").get<double>() == 0.0);
  CHECK(j2.at("session").get<int>() == 2);
  CHECK(j2.at("reversed").get<bool>());
  CHECK(j2.at("odometry_reset_at").get<int>() == 4);
  CHECK(j2.at("start_offset_m").get<double>() > 0.0);
  CHECK(j2.at("start_utime").get<std::int64_t>() - j1.at("start_utime").get<std::int64_t>() == std::int64_t{86400000000});

  REQUIRE(run(tool_path() + " --help", &help) == 0);
  for (const char* word : {"--session", "--odometry-reset-at", "opposite direction", "ring"}) {
    CAPTURE(word);
    CHECK(help.find(word) != std::string::npos);
  }
  for (const char* bad : {"--session 0", "--session 1001", "--odometry-reset-at 0", "--odometry-reset-at 12"}) {
    CAPTURE(bad);
    std::string err;
    CHECK(run("(" + base + (dir / "bad.lcmlog").string() + " " + bad + " 2>&1)", &err) != 0);  // stderr into err
    CHECK(err.find("must be in [1, ") != std::string::npos);
  }
  fs::remove_all(dir);
}
