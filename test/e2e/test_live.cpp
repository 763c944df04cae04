// Live mode: loopd listens on UDP multicast (ttl=0, routed through loopback), lcm-logplayer plays a simulated drive
// at 1x, lcm-logger records what loopd publishes. The accepted loops must be those of a replay of the same drive,
// and status must show nothing dropped. Skips when multicast is not routed through loopback (needs root to set up:
// scripts/test does it).
#include <catch2/catch.hpp>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <loopd/loop_event_t.hpp>
#include <loopd/status_t.hpp>

#include "lcm_log.hpp"
#include "support/headless_chromium.hpp"
#include "support/http_client.hpp"
#include "support/process.hpp"
#include "support/hostile_log.hpp"
#include "message_convert.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {
const std::string kBin = LOOPD_BINARY_DIR;

using loopd::test::spawn;

struct Published {
  std::set<std::pair<std::int64_t, std::int64_t>> accepted;  // (query utime, match utime)
  status_t status{};
  bool has_status = false;
};

/// The samples of a Prometheus text page, by name with labels (comments left out).
std::map<std::string, double> parse_metrics(const std::string& text) {
  std::map<std::string, double> samples;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    const std::size_t space = line.rfind(' ');
    if (space != std::string::npos) samples[line.substr(0, space)] = std::stod(line.substr(space + 1));
  }
  return samples;
}

Published read_published(const std::string& path) {
  Published p;
  LogReader r;
  std::string error;
  if (!r.open(path, &error)) return p;
  LogEvent ev;
  while (r.next(&ev)) {
    if (ev.channel == channels::kLoopEvent) {
      loop_event_t e;
      if (LogReader::decode(ev, &e) && e.status == loop_event_t::STATUS_ACCEPTED) p.accepted.insert({e.query_utime, e.match_utime});
    } else if (ev.channel == channels::kStatus) {
      p.has_status = LogReader::decode(ev, &p.status) || p.has_status;
    }
  }
  return p;
}
}  // namespace

TEST_CASE("live at 1x beside lcm-logplayer makes the replay's decisions, drops nothing and survives crafted scans", "[live]") {
  if (loopd::test::run_quiet("ip route get 239.255.76.67 | grep -q 'dev lo'") != 0) {
    WARN(
        "skipped: multicast 239.255.76.0/24 is not routed through loopback (as root: ip link set lo multicast on; "
        "ip route add 239.255.76.0/24 dev lo)");
    return;
  }
  const fs::path dir = fs::temp_directory_path() / ("loopd_live_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string drive = (dir / "drive.lcmlog").string();
  REQUIRE(loopd::test::run_quiet(kBin + "/tools/loopd-sim/loopd-sim --out " + drive +
                                 " --sensor vlp16 --scans 340 --seed 11 --route block --quiet") == 0);
  REQUIRE(loopd::test::run_quiet(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive + " --output " + (dir / "replay.lcmlog").string()) ==
          0);
  const Published replay = read_published((dir / "replay.lcmlog").string());

  const std::string port = std::to_string(7700 + getpid() % 200);
  const std::string url = "udpm://239.255.76.67:" + port + "?ttl=0&recv_buf_size=8388608";
  const int http_port = 7700 + static_cast<int>(getpid() % 200);  // TCP: apart from the UDP port of the same number
  const pid_t loopd =
      spawn({kBin + "/daemon/loopd", "--sensor", "vlp16", "--quiet", "--lcm-url", url, "--http", "127.0.0.1:" + std::to_string(http_port)});
  const pid_t logger =
      spawn({"lcm-logger", "--lcm-url=" + url, "-c", "LOOP_EVENT|CORRECTED_TRAJECTORY|LOOPD_STATUS", "-f", (dir / "live.lcmlog").string()});
  std::this_thread::sleep_for(std::chrono::seconds(2));
  // The drive as played carries the crafted scans that used to stop loopd (bounded decoding must count them).
  const std::string played = (dir / "played.lcmlog").string();
  REQUIRE(loopd::test::copy_with_crafted_scans(drive, played, channels::kScan, 200, false) == 3);
  REQUIRE(loopd::test::run_quiet("lcm-logplayer -l '" + url + "' -s 1 -e 'LIDAR_SCAN|ODOMETRY_POSE' " + played) == 0);
  std::this_thread::sleep_for(std::chrono::seconds(4));  // let the workers finish and a status go out
  // --http while it runs: /healthz, and /metrics from the newest status (idle now: the same counters as the last
  // status_t published, checked below).
  const loopd::test::HttpReply health = loopd::test::http_request(http_port, "GET", "/healthz");
  CHECK(health.status == 200);
  CHECK(health.body == "ok\n");
  const loopd::test::HttpReply metrics = loopd::test::http_request(http_port, "GET", "/metrics");
  CHECK(metrics.status == 200);
  CHECK(loopd::test::http_request(http_port, "POST", "/metrics").status == 405);
  CHECK(loopd::test::http_request(http_port, "GET", "/../etc/passwd").status == 404);
  // The live page in a real browser (headless Chromium): the DOM once the WebSocket data came, and a screenshot.
  const std::string page_url = "http://127.0.0.1:" + std::to_string(http_port) + "/";
  const bool browser = loopd::test::chromium_available();
  const std::string dom = browser ? loopd::test::chromium_dom(page_url) : "";
  const std::string png = (dir / "page.png").string();
  const bool screenshot = browser && loopd::test::chromium_screenshot(page_url, png);
  CHECK(loopd::test::stop_process(loopd) == 0);
  loopd::test::stop_process(logger);

  const Published live = read_published((dir / "live.lcmlog").string());
  REQUIRE(live.has_status);
  REQUIRE(live.status.num_channels == 2);
  CHECK(live.status.channels[0].received == 343);
  CHECK(live.status.channels[0].malformed == 3);
  CHECK(live.status.channels[0].dropped == 0);
  CHECK(live.status.scans_lost_estimate == 0);
  CHECK(live.status.clock_jumps == 0);
  CHECK(live.status.odometry_resets == 0);
  CHECK(live.status.channels[1].received == 340);
  CHECK(live.status.shed == 0);
  CHECK(live.accepted.size() >= 10);
  CHECK(live.accepted == replay.accepted);
  std::map<std::string, double> m = parse_metrics(metrics.body);
  INFO(metrics.body);
  CHECK(m["loopd_up"] == 1);
  CHECK(m["loopd_channel_received_total{channel=\"" + std::string(live.status.channels[0].channel) + "\"}"] == 343);
  CHECK(m["loopd_channel_malformed_total{channel=\"" + std::string(live.status.channels[0].channel) + "\"}"] == 3);
  CHECK(m["loopd_channel_received_total{channel=\"" + std::string(live.status.channels[1].channel) + "\"}"] == 340);
  CHECK(m["loopd_keyframes"] == static_cast<double>(live.status.keyframes));
  CHECK(m["loopd_loops_accepted_total"] == static_cast<double>(live.status.loops_accepted));
  CHECK(m["loopd_loops_rejected_total"] == static_cast<double>(live.status.loops_rejected));
  CHECK(m["loopd_shed_total"] == 0);
  CHECK(m["loopd_resident_memory_bytes"] > 1e7);
  CHECK(m.count("loopd_descriptor_device_info{device=\"" + std::string(live.status.device) + "\"}") == 1);
  if (!browser) {
    WARN("skipped the browser checks: chromium is not installed (apt install chromium)");
  } else {
    // Every published loop is on the page, and its funnel is status_t's.
    INFO(dom.substr(0, 3000));
    CHECK(loopd::test::body_attribute(dom, "data-state") == "synced");
    CHECK(loopd::test::element_text(dom, "loops-shown") == std::to_string(live.accepted.size()));
    CHECK(loopd::test::element_text(dom, "funnel-accepted") == std::to_string(live.status.loops_accepted));
    CHECK(loopd::test::element_text(dom, "funnel-rejected") == std::to_string(live.status.loops_rejected));
    CHECK(loopd::test::element_text(dom, "funnel-keyframes") == std::to_string(live.status.keyframes));
    CHECK(loopd::test::element_text(dom, "funnel-scans") == std::to_string(live.status.channels[0].received));
    CHECK(loopd::test::element_text(dom, "health-shed") == "0");
    CHECK(loopd::test::element_text(dom, "health-watchdog") == "ok");
    REQUIRE(screenshot);
    CHECK(fs::file_size(png) > 50000);  // a drawn page, not a blank one
    fs::create_directories(kBin + "/test-artifacts");
    fs::copy_file(png, kBin + "/test-artifacts/live_page.png", fs::copy_options::overwrite_existing);
  }
  fs::remove_all(dir);
}
