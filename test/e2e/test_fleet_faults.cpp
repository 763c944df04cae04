// The fleet's fault cases (issue 16) on a real PostgreSQL server the test starts itself (scripts/pg-local: initdb in
// a temporary folder, a Unix socket only, an unprivileged user when run as root): a vehicle SIGKILLed mid-drive and
// restarted resumes its session while the other goes on; the server restarted mid-run loses nothing loopd published;
// a wrong password or an unreachable server is a clear error at start. Skipped when the server binaries are missing.
#include <catch2/catch.hpp>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <sys/wait.h>
#include <thread>
#include <tuple>
#include <unistd.h>

#include <loopd/loop_event_t.hpp>
#include <loopd/trajectory_t.hpp>

#include "bounded_decode.hpp"
#include "lcm_log.hpp"
#include "loopd/store/map_store.hpp"
#include "loopd/store/shared_map.hpp"
#include "loopd/records/vehicle_sessions.hpp"
#include "support/process.hpp"
#include "support/run_command.hpp"
#include "support/temp_dir.hpp"

using namespace loopd;

namespace {

const std::string kBin = LOOPD_BINARY_DIR;
const std::string kSrc = LOOPD_SOURCE_DIR;

/// A decision as published and as stored: (query session, query index, match session, match index, status).
using Decision = std::tuple<std::int32_t, std::int64_t, std::int32_t, std::int64_t, int>;

struct Published {
  std::multiset<Decision> decisions;
  std::size_t last_trajectory_keyframes = 0;
  std::int64_t last_revision = -1;
};

Published read_output(const std::string& path) {
  Published p;
  LogReader reader;
  std::string error;
  if (!reader.open(path, &error)) return p;
  LogEvent e;
  while (reader.next(&e)) {
    if (e.channel == "LOOP_EVENT") {
      loop_event_t m;
      if (decode_bounded(e.data.data(), e.data.size(), DecodeLimits{}, &m).ok)
        p.decisions.insert({m.query_session, m.query_id, m.match_session, m.match_id, m.status});
    } else if (e.channel == "CORRECTED_TRAJECTORY") {
      trajectory_t t;
      if (!decode_bounded(e.data.data(), e.data.size(), DecodeLimits{}, &t).ok) continue;
      p.last_revision = t.revision;
      if (t.full) p.last_trajectory_keyframes = static_cast<std::size_t>(t.num_keyframes);
    }
  }
  return p;
}

std::multiset<Decision> stored_decisions(MapStore& store) {
  std::multiset<Decision> out;
  store.for_each_loop(false, [&](LoopDecision&& r) {
    out.insert({r.query.session, r.query.index, r.match.session, r.match.index, status_code(r.status)});
  });
  return out;
}

std::unique_ptr<MapStore> open_whole_map(const std::string& uri) {
  MapStoreConfig c;
  c.uri = uri;
  c.read_only = true;
  OpenedMapStore opened = open_map_store(c);
  INFO(opened.status.message);
  REQUIRE(opened.status.ok());
  return std::move(opened.store);
}

/// Keyframes of `session` in the map (0 while loopd has not made the map yet).
std::int64_t keyframes_of(const std::string& uri, SessionId session) {
  MapStoreConfig c;
  c.uri = uri;
  c.read_only = true;
  OpenedMapStore opened = open_map_store(c);
  std::int64_t n = 0;
  if (opened.status.ok()) opened.store->for_each_keyframe(session, KeyframeLoad::kPose, [&](MapKeyframe&&) { ++n; });
  return n;
}

/// A PostgreSQL server of the test's own (scripts/pg-local), stopped and removed at the end.
class LocalServer {
 public:
  explicit LocalServer(const std::string& dir) : dir_(dir) {
    // As root the server runs as nobody, who must reach DIR/pg through the test's own (0700) folder.
    std::filesystem::permissions(dir, std::filesystem::perms::others_exec, std::filesystem::perm_options::add);
    int rc = 0;
    const std::string out = test::run_command(kSrc + "/scripts/pg-local start " + dir + "/pg --password fleettest 2>&1", &rc);
    available_ = rc == 0;
    if (available_) uri_ = test::last_line(out);
    reason_ = out;
  }
  ~LocalServer() {
    if (available_) test::run_quiet(kSrc + "/scripts/pg-local stop " + dir_ + "/pg --mode immediate");
  }
  bool available() const { return available_; }
  const std::string& uri() const { return uri_; }
  const std::string& reason() const { return reason_; }
  int stop() { return test::run_quiet(kSrc + "/scripts/pg-local stop " + dir_ + "/pg --mode fast"); }
  int start() { return test::run_quiet(kSrc + "/scripts/pg-local start " + dir_ + "/pg --password fleettest"); }

 private:
  std::string dir_, uri_, reason_;
  bool available_ = false;
};

std::string simulate(const test::TempDir& dir, int session, int scans) {
  const std::string drive = dir.file("drive" + std::to_string(session) + ".lcmlog");
  int rc = 0;
  const std::string out = test::run_command(kBin + "/tools/loopd-sim/loopd-sim --out " + drive + " --sensor vlp16 --scans " + std::to_string(scans) +
                                                " --seed 5 --session " + std::to_string(session) + " --route block --quiet",
                                            &rc);
  INFO(out);
  REQUIRE(rc == 0);
  return drive;
}

pid_t start_vehicle(const test::TempDir& dir, const std::string& uri, int vehicle, const std::string& drive) {
  const std::string v = std::to_string(vehicle);
  const std::string cmd = "exec " + kBin + "/daemon/loopd --sensor vlp16 --quiet --threads 1 --replay " + drive + " --output " +
                          dir.file("results" + v + ".lcmlog") + " --map '" + uri + "' --vehicle " + v + " 2>>" + dir.file("stderr" + v + ".txt");
  return test::spawn({"/bin/sh", "-c", cmd});
}

int wait_for(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Waits (up to 120 s) until the map holds `n` keyframes of `session`.
bool wait_for_keyframes(const std::string& uri, SessionId session, std::int64_t n) {
  for (int i = 0; i < 1200; ++i) {
    if (keyframes_of(uri, session) >= n) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return false;
}

}  // namespace

TEST_CASE("fleet: a wrong password or an unreachable server stops loopd at start with a clear error") {
  test::TempDir dir("loopd_fleet_refused");
  LocalServer server(dir.path());
  if (!server.available()) {
    WARN("skipped: no PostgreSQL server: " << server.reason());
    return;
  }
  const std::string drive = simulate(dir, 1, 20);
  std::string wrong = server.uri();
  const auto at = wrong.find("fleettest");
  REQUIRE(at != std::string::npos);
  wrong.replace(at, 9, "guessedpw");
  int rc = 0;
  std::string out = test::run_command(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive + " --map '" + wrong + "' 2>&1", &rc);
  INFO(out);
  CHECK(rc == 2);
  CHECK(out.find("cannot use the map") != std::string::npos);
  CHECK(out.find("password authentication failed") != std::string::npos);
  CHECK(out.find("guessedpw") == std::string::npos);  // the password is never printed

  const std::string nowhere = "postgresql://loopd@/loopd?host=" + dir.file("no-server-here");
  out = test::run_command(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive + " --map '" + nowhere + "' 2>&1", &rc);
  INFO(out);
  CHECK(rc == 2);
  CHECK(out.find("cannot use the map") != std::string::npos);
  CHECK(out.find("no-server-here") != std::string::npos);
}

TEST_CASE("fleet: a vehicle killed with SIGKILL resumes its session on restart, the other goes on, and they share loops") {
  test::TempDir dir("loopd_fleet_kill");
  LocalServer server(dir.path());
  if (!server.available()) {
    WARN("skipped: no PostgreSQL server: " << server.reason());
    return;
  }
  const std::string drive1 = simulate(dir, 1, 260), drive2 = simulate(dir, 2, 260);
  const pid_t v1 = start_vehicle(dir, server.uri(), 1, drive1);
  pid_t v2 = start_vehicle(dir, server.uri(), 2, drive2);
  REQUIRE(wait_for_keyframes(server.uri(), 2000000, 40));
  kill(v2, SIGKILL);
  wait_for(v2);
  const Published before_kill = read_output(dir.file("results2.lcmlog"));
  v2 = start_vehicle(dir, server.uri(), 2, drive2);
  CHECK(wait_for(v2) == 0);
  CHECK(wait_for(v1) == 0);
  INFO(read_file(dir.file("stderr2.txt")));

  std::unique_ptr<MapStore> map = open_whole_map(server.uri());
  const StoreStatus check = map->check();
  INFO(check.message);
  CHECK(check.ok());
  // Vehicle 2 went on in its own session (no new one opened by the restart).
  std::set<SessionId> sessions;
  for (const SessionRecord& s : map->sessions().value) sessions.insert(s.id);
  CHECK(sessions == std::set<SessionId>{1000000, 2000000});
  // Nothing either vehicle published is missing from the map, the part before the kill included.
  const std::multiset<Decision> stored = stored_decisions(*map);
  for (const int v : {1, 2})
    for (const Decision& d : read_output(dir.file("results" + std::to_string(v) + ".lcmlog")).decisions) CHECK(stored.count(d) >= 1);
  for (const Decision& d : before_kill.decisions) CHECK(stored.count(d) >= 1);
  // Loops between the vehicles were accepted, and the joint correction ties vehicle 2 into vehicle 1's map.
  int inter_vehicle = 0;
  for (const Decision& d : stored) inter_vehicle += std::get<4>(d) == 1 && vehicle_of(std::get<0>(d)) != vehicle_of(std::get<2>(d));
  CHECK(inter_vehicle >= 2);
  REQUIRE(map->shared());
  const StoreResult<std::optional<FleetCorrectionRecord>> joint = map->shared()->fleet_correction();
  REQUIRE(joint.ok());
  REQUIRE(joint.value);
  REQUIRE(joint.value->sessions.size() == 2);
  CHECK(joint.value->sessions[1].id == 2000000);
  CHECK(joint.value->sessions[1].anchored);
}

TEST_CASE("fleet: the server restarted mid-run, loopd keeps detecting, buffers, reconnects and stores all it published") {
  test::TempDir dir("loopd_fleet_restart");
  LocalServer server(dir.path());
  if (!server.available()) {
    WARN("skipped: no PostgreSQL server: " << server.reason());
    return;
  }
  const std::string drive = simulate(dir, 1, 260);
  const pid_t v1 = start_vehicle(dir, server.uri(), 1, drive);
  REQUIRE(wait_for_keyframes(server.uri(), 1000000, 30));
  REQUIRE(server.stop() == 0);
  std::this_thread::sleep_for(std::chrono::seconds(3));
  REQUIRE(server.start() == 0);
  CHECK(wait_for(v1) == 0);
  const std::string log = read_file(dir.file("stderr1.txt"));
  INFO(log);
  CHECK(log.find("buffering") != std::string::npos);
  CHECK(log.find("every buffered write is stored") != std::string::npos);

  const Published published = read_output(dir.file("results1.lcmlog"));
  std::unique_ptr<MapStore> map = open_whole_map(server.uri());
  CHECK(map->check().ok());
  const std::multiset<Decision> stored = stored_decisions(*map);
  CHECK(published.decisions.size() >= 20);
  CHECK(stored == published.decisions);
  // The last trajectory (the joint correction after the flush) covers every stored keyframe.
  CHECK(static_cast<std::int64_t>(published.last_trajectory_keyframes) == keyframes_of(server.uri(), 1000000));
  CHECK(published.last_trajectory_keyframes > 30);
}
