// The live page (docs/web.md) of a stored map in a real browser: `loopd-map FILE serve --http` on a two-session map,
// opened in headless Chromium (Debian's chromium); the DOM must show every keyframe, every stored decision and every
// accepted loop of the map, both sessions, and the funnel of the map's counts. Skips the browser part without chromium.
#include <catch2/catch.hpp>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>
#include <unistd.h>

#include "support/headless_chromium.hpp"
#include "support/http_client.hpp"
#include "support/process.hpp"
#include "support/run_command.hpp"

namespace fs = std::filesystem;

namespace {
const std::string kBin = LOOPD_BINARY_DIR;

using loopd::test::run_ok;
}  // namespace

TEST_CASE("loopd-map serve: a stored two-session map in headless Chromium shows every keyframe, decision and loop of the map") {
  const fs::path dir = fs::temp_directory_path() / ("loopd_web_page_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string map = (dir / "map.db").string();
  for (int session = 0; session < 2; ++session) {
    const std::string drive = (dir / ("drive" + std::to_string(session) + ".lcmlog")).string();
    run_ok(kBin + "/tools/loopd-sim/loopd-sim --route block --sensor vlp16 --quiet --seed 21 --session " + std::to_string(session + 1) +
           " --scans 220 --out " + drive);
    run_ok(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive + " --map " + map);
  }
  const nlohmann::json info = nlohmann::json::parse(loopd::test::last_line(run_ok(kBin + "/tools/loopd-map/loopd-map " + map + " info --json")));
  REQUIRE(info["sessions"] == 2);
  REQUIRE(info["loops_accepted"].get<int>() >= 10);

  // One rejected decision's stage as a map made by someone else might hold it: markup, which the page must show as text.
  run_ok("sqlite3 " + map +
         " \"UPDATE loops SET stage = '<b id=injected>x</b>' WHERE event_id = (SELECT MIN(event_id) FROM loops WHERE stage != 'accepted')\"");

  const int port = 7900 + static_cast<int>(getpid() % 100);
  const pid_t serve = loopd::test::spawn({kBin + "/tools/loopd-map/loopd-map", map, "serve", "--http", std::to_string(port)});
  int status = 0;
  for (int i = 0; i < 100 && status != 200; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    status = loopd::test::http_request(port, "GET", "/").status;
  }
  REQUIRE(status == 200);
  CHECK(loopd::test::http_request(port, "GET", "/metrics").status == 404);  // a stored map has no daemon's metrics

  if (!loopd::test::chromium_available()) {
    WARN("skipped the browser checks: chromium is not installed (apt install chromium)");
  } else {
    const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/";
    const std::string dom = loopd::test::chromium_dom(url);
    INFO(dom.substr(0, 2000));
    CHECK(loopd::test::body_attribute(dom, "data-state") == "synced");
    CHECK(loopd::test::body_attribute(dom, "data-keyframes") == std::to_string(info["keyframes"].get<int>()));
    CHECK(loopd::test::element_text(dom, "loops-shown") == std::to_string(info["loops_accepted"].get<int>()));
    CHECK(loopd::test::element_text(dom, "decisions-shown") == std::to_string(info["loops_accepted"].get<int>() + info["loops_rejected"].get<int>()));
    CHECK(loopd::test::element_text(dom, "funnel-accepted") == std::to_string(info["loops_accepted"].get<int>()));
    CHECK(loopd::test::element_text(dom, "funnel-rejected") == std::to_string(info["loops_rejected"].get<int>()));
    CHECK(loopd::test::element_text(dom, "health-sessions") == "2");
    CHECK(dom.find("session 0") != std::string::npos);  // the legend: each session in its own colour
    CHECK(dom.find("session 1") != std::string::npos);
    CHECK(dom.find("id=\"injected\"") == std::string::npos);                   // no element made from the map's text
    CHECK(dom.find("&lt;b id=injected&gt;x&lt;/b&gt;") != std::string::npos);  // shown as text
    const std::string png = (dir / "page.png").string();
    REQUIRE(loopd::test::chromium_screenshot(url, png));
    CHECK(fs::file_size(png) > 50000);  // a drawn page, not a blank one (a blank 1500 x 1100 PNG is ~10 KB)
    fs::create_directories(kBin + "/test-artifacts");
    fs::copy_file(png, kBin + "/test-artifacts/map_page.png", fs::copy_options::overwrite_existing);
  }
  CHECK(loopd::test::stop_process(serve) == 0);
  fs::remove_all(dir);
}
