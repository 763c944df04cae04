// Fault matrix: one simulated VLP-16 drive (loopd-sim, block route, revisits) is copied with one fault each (scans
// dropped, a pose gap, data clock steps back and forward, duplicated and reordered messages, another lidar spliced
// in, an odometry restart) and replayed by the loopd daemon; a scan flood and a lossy drive are also played live
// beside lcm-logplayer. For every fault: loopd exits cleanly, its last status_t says what happened, no wrong loop is
// accepted (loopd-eval closure precision 1.0 against ground truth) and memory stays within 2x the clean run + 200 MB.
#include <catch2/catch.hpp>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <loopd/loop_event_t.hpp>
#include <loopd/status_t.hpp>

#include "lcm_log.hpp"
#include "support/process.hpp"
#include "message_convert.hpp"
#include "support/fault_log.hpp"
#include "support/run_command.hpp"

using namespace loopd;
namespace fs = std::filesystem;
using loopd::test::FaultResult;

namespace {
const std::string kBin = LOOPD_BINARY_DIR;
constexpr int kScans = 340;                 // one lap of the block (~244 m) and a second visit of its first ~96 m
constexpr std::int64_t kPeriodUs = 100000;  // loopd-sim's 10 Hz
constexpr int kMiddle = kScans / 2;         // faults that start mid-drive start at this scan (before the revisit)

/// What one loopd run published, and what loopd-eval made of it.
struct Outcome {
  int exit_code = -1;
  std::string log;
  status_t status{};
  bool has_status = false;
  std::set<std::pair<std::int64_t, std::int64_t>> accepted;  ///< (query utime, match utime)
  int eval_accepted = 0;
  int eval_correct = 0;
  double closure_precision = -1.0;
  std::string eval_log;
  double seconds = 0.0;
};

void read_published(const std::string& path, Outcome* o) {
  LogReader r;
  std::string error;
  if (!r.open(path, &error)) return;
  LogEvent ev;
  while (r.next(&ev)) {
    if (ev.channel == channels::kLoopEvent) {
      loop_event_t e;
      if (LogReader::decode(ev, &e) && e.status == loop_event_t::STATUS_ACCEPTED) o->accepted.insert({e.query_utime, e.match_utime});
    } else if (ev.channel == channels::kStatus) {
      status_t s;
      if (LogReader::decode(ev, &s)) {
        o->status = s;
        o->has_status = true;
      }
    }
  }
}

void evaluate(const std::string& drive, const std::string& results, Outcome* o) {
  int rc = 0;
  o->eval_log = loopd::test::run_command(kBin + "/tools/loopd-eval/loopd-eval --json --quiet --drive " + drive + " --results " + results, &rc);
  if (rc != 0) return;
  const auto j = nlohmann::json::parse(loopd::test::last_line(o->eval_log), nullptr, false);
  if (j.is_discarded()) return;
  o->eval_accepted = j.value("accepted", 0);
  o->eval_correct = j.value("correct", 0);
  o->closure_precision = j.value("closure_precision", -1.0);
}

Outcome replay(const std::string& drive, const std::string& out) {
  Outcome o;
  const auto t0 = std::chrono::steady_clock::now();
  o.log = loopd::test::run_command(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive + " --output " + out, &o.exit_code);
  read_published(out, &o);
  evaluate(drive, out, &o);
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return o;
}

/// The drive, its clean replay and (made on first use) the same drive seen by an HDL-32E, shared by all sections.
struct SharedDrive {
  fs::path dir;
  std::string drive, hdl32;
  Outcome clean;
  std::vector<std::int64_t> scan_utimes;
  std::string error;

  bool keep = false;  ///< LOOPD_FAULT_KEEP=<dir>: make everything there and leave it

  SharedDrive() {
    const char* keep_dir = std::getenv("LOOPD_FAULT_KEEP");
    keep = keep_dir != nullptr && *keep_dir != '\0';
    dir = keep ? fs::path(keep_dir) : fs::temp_directory_path() / ("loopd_faults_" + std::to_string(getpid()));
    fs::create_directories(dir);
    drive = (dir / "drive.lcmlog").string();
    int rc = 0;
    const std::string log = loopd::test::run_command(
        kBin + "/tools/loopd-sim/loopd-sim --out " + drive + " --sensor vlp16 --scans " + std::to_string(kScans) + " --seed 11 --route block --quiet",
        &rc);
    if (rc != 0) {
      error = "loopd-sim failed: " + log;
      return;
    }
    scan_utimes = loopd::test::channel_utimes(drive, channels::kScan);
    clean = replay(drive, (dir / "clean_out.lcmlog").string());
  }
  ~SharedDrive() {
    if (keep) return;
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  /// The same route, seed and odometry with an HDL-32E (32 rings, about 2x the points): loopd-sim's trajectory
  /// does not depend on the lidar model, so its scans drop into the VLP-16 drive at the same utimes.
  const std::string& hdl32_drive() {
    if (hdl32.empty()) {
      const std::string path = (dir / "drive_hdl32.lcmlog").string();
      int rc = 0;
      loopd::test::run_command(kBin + "/tools/loopd-sim/loopd-sim --out " + path + " --sensor hdl32 --scans " + std::to_string(kScans) +
                                   " --seed 11 --route block --quiet",
                               &rc);
      if (rc == 0) hdl32 = path;
    }
    return hdl32;
  }
  std::int64_t middle_utime() const { return scan_utimes.at(kMiddle); }
};

SharedDrive& shared_drive() {
  static SharedDrive d;
  return d;
}

/// A fault's copy (<fault>.lcmlog) and loopd's output (<fault>_out.lcmlog) in the shared dir; removed after the
/// section unless LOOPD_FAULT_KEEP is set (to reproduce a case by hand).
struct FaultFiles {
  std::string drive, out;
  bool keep = false;
  FaultFiles(const SharedDrive& d, const std::string& name) : keep(d.keep) {
    drive = (d.dir / (name + ".lcmlog")).string();
    out = (d.dir / (name + "_out.lcmlog")).string();
  }
  ~FaultFiles() {
    if (keep) return;
    std::error_code ec;
    fs::remove(drive, ec);
    fs::remove(out, ec);
  }
};

void print_row(const std::string& fault, const std::string& what, const Outcome& o, const SharedDrive& d) {
  const auto& s = o.status;
  std::cout << "fault-matrix | " << fault << " | " << what << " | rc " << o.exit_code << " | scans recv/acc/drop "
            << (s.num_channels > 0 ? s.channels[0].received : -1) << "/" << (s.num_channels > 0 ? s.channels[0].accepted : -1) << "/"
            << (s.num_channels > 0 ? s.channels[0].dropped : -1) << " poses recv/acc " << (s.num_channels > 1 ? s.channels[1].received : -1) << "/"
            << (s.num_channels > 1 ? s.channels[1].accepted : -1) << " | invalid " << s.invalid_scans << " lost~ " << s.scans_lost_estimate
            << " jumps " << s.clock_jumps << " resets " << s.odometry_resets << " sensor " << s.sensor_changes << " shed " << s.shed
            << " | keyframes " << s.keyframes << " (clean " << d.clean.status.keyframes << ") | loops " << o.accepted.size() << " (clean "
            << d.clean.accepted.size() << "), eval " << o.eval_correct << "/" << o.eval_accepted << " correct, precision " << o.closure_precision
            << " | memory " << s.memory_bytes / 1000000 << " MB (clean " << d.clean.status.memory_bytes / 1000000 << ") | " << o.seconds << " s\n";
}

/// What every fault must keep: the daemon stays up and exits 0, publishes status, accepts no wrong loop, and its
/// memory stays within 2x the clean run's + 200 MB.
void check_common(const Outcome& o, const SharedDrive& d) {
  INFO(o.log);
  INFO(o.eval_log);
  CHECK(o.exit_code == 0);
  REQUIRE(o.has_status);
  REQUIRE(o.status.num_channels == 2);
  if (!o.accepted.empty()) {
    CHECK(o.eval_accepted == static_cast<int>(o.accepted.size()));
    CHECK(o.closure_precision == 1.0);
  }
  CHECK(o.status.memory_bytes > 0);
  CHECK(o.status.memory_bytes < 2 * d.clean.status.memory_bytes + 200'000'000);
}

/// Scans the daemon received but rejected as out of order / duplicate, and poses likewise.
std::int64_t rejected(const status_t& s, int channel) {
  const auto& c = s.channels[static_cast<std::size_t>(channel)];
  return c.received - c.accepted - c.malformed;
}

using loopd::test::spawn;

/// loopd live on UDP multicast (ttl=0, loopback) while lcm-logplayer plays `drive` at `speed`; lcm-logger records.
Outcome live(const std::string& drive, double speed, const std::string& out) {
  Outcome o;
  const auto t0 = std::chrono::steady_clock::now();
  const std::string port = std::to_string(7900 + getpid() % 100);  // test_live uses 7700..7899
  const std::string url = "udpm://239.255.76.67:" + port + "?ttl=0&recv_buf_size=8388608";
  const pid_t loopd = spawn({kBin + "/daemon/loopd", "--sensor", "vlp16", "--quiet", "--lcm-url", url});
  const pid_t logger = spawn({"lcm-logger", "--lcm-url=" + url, "-c", "LOOP_EVENT|CORRECTED_TRAJECTORY|LOOPD_STATUS", "-f", out});
  std::this_thread::sleep_for(std::chrono::seconds(2));
  const int player = loopd::test::run_quiet("lcm-logplayer -l '" + url + "' -s " + std::to_string(speed) + " -e 'LIDAR_SCAN|ODOMETRY_POSE' " + drive);
  std::this_thread::sleep_for(std::chrono::seconds(4));  // let the workers finish and a status go out
  o.exit_code = loopd::test::stop_process(loopd);
  loopd::test::stop_process(logger);
  o.log = "lcm-logplayer exit " + std::to_string(player);
  read_published(out, &o);
  evaluate(drive, out, &o);
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return o;
}

}  // namespace

TEST_CASE("fault matrix, replay: every input fault is counted, no wrong loop is accepted, memory stays bounded") {
  SharedDrive& d = shared_drive();
  INFO(d.error);
  REQUIRE(d.error.empty());
  REQUIRE(d.scan_utimes.size() == static_cast<std::size_t>(kScans));

  SECTION("clean drive: the reference") {
    INFO(d.clean.log);
    check_common(d.clean, d);
    print_row("clean", "-", d.clean, d);
    CHECK(d.clean.accepted.size() >= 10);
    CHECK(d.clean.status.scans_lost_estimate == 0);
    CHECK(d.clean.status.clock_jumps == 0);
    CHECK(d.clean.status.odometry_resets == 0);
    CHECK(d.clean.status.sensor_changes == 0);
  }

  for (const double fraction : {0.1, 0.5}) {
    DYNAMIC_SECTION("scans dropped: " << fraction * 100 << " %") {
      const FaultFiles files(d, "drop" + std::to_string(static_cast<int>(fraction * 100)));
      const std::string& faulty = files.drive;
      const std::string& out = files.out;
      const FaultResult f = loopd::test::drop_messages(d.drive, faulty, channels::kScan, fraction, 11);
      INFO(f.error);
      REQUIRE(f.ok);
      REQUIRE(f.affected > 0);
      const Outcome o = replay(faulty, out);
      print_row("drop " + std::to_string(static_cast<int>(fraction * 100)) + "%", std::to_string(f.affected) + " scans dropped", o, d);
      check_common(o, d);
      INFO(o.log);
      CHECK(o.status.channels[0].received == kScans - f.affected);
      // Never received, so only the scan-rate gaps can tell: the estimate within 30 % of the truth.
      CHECK(o.status.scans_lost_estimate >= static_cast<std::int64_t>(0.7 * static_cast<double>(f.affected)));
      CHECK(o.status.scans_lost_estimate <= static_cast<std::int64_t>(1.3 * static_cast<double>(f.affected)));
      CHECK(o.status.clock_jumps == 0);
      CHECK(o.status.odometry_resets == 0);
      CHECK(o.status.sensor_changes == 0);
    }
  }

  SECTION("poses missing for 5 s") {
    const FaultFiles files(d, "pose_gap");
    const std::string& faulty = files.drive;
    const std::string& out = files.out;
    const std::int64_t from = d.middle_utime(), to = from + 5'000'000;
    const FaultResult f = loopd::test::remove_window(d.drive, faulty, channels::kPose, from, to);
    INFO(f.error);
    REQUIRE(f.ok);
    REQUIRE(f.affected == 50);
    const Outcome o = replay(faulty, out);
    print_row("pose gap 5 s", std::to_string(f.affected) + " poses removed", o, d);
    check_common(o, d);
    INFO(o.log);
    // Every scan arrived; the 50 scans of the gap have no pose within the association tolerance: dropped, and said so.
    CHECK(o.status.channels[0].received == kScans);
    CHECK(o.status.channels[0].dropped == f.affected);
    CHECK(o.status.channels[1].received == kScans - f.affected);
    CHECK(o.status.scans_lost_estimate == 0);  // missing poses are not missing scans
    CHECK(o.status.odometry_resets == 0);      // 50 m in 5 s is a drive, not a reset
    CHECK(o.status.clock_jumps == 0);
  }

  SECTION("data clock steps back 60 s mid-drive (logger clock monotonic)") {
    const FaultFiles files(d, "clock_back");
    const std::string& faulty = files.drive;
    const std::string& out = files.out;
    const FaultResult f = loopd::test::shift_clock(d.drive, faulty, d.middle_utime(), -60'000'000);
    INFO(f.error);
    REQUIRE(f.ok);
    REQUIRE(f.affected == 3 * (kScans - kMiddle));
    const Outcome o = replay(faulty, out);
    print_row("clock -60 s", std::to_string(f.affected) + " messages re-stamped", o, d);
    check_common(o, d);
    INFO(o.log);
    CHECK(o.status.clock_jumps == 1);
    // A backward step is followed once 2 messages confirm it: at most the first one of each channel is lost.
    CHECK(o.status.channels[0].accepted >= kScans - 1);
    CHECK(o.status.channels[1].accepted >= kScans - 1);
    CHECK(o.status.scans_lost_estimate == 0);
    CHECK(o.status.odometry_resets == 0);
    // The revisit comes after the step: its loops are still found.
    CHECK(o.accepted.size() >= d.clean.accepted.size() / 2);
  }

  SECTION("data clock steps forward 3600 s mid-drive") {
    const FaultFiles files(d, "clock_forward");
    const std::string& faulty = files.drive;
    const std::string& out = files.out;
    const FaultResult f = loopd::test::shift_clock(d.drive, faulty, d.middle_utime(), 3600'000'000LL);
    INFO(f.error);
    REQUIRE(f.ok);
    const Outcome o = replay(faulty, out);
    print_row("clock +3600 s", std::to_string(f.affected) + " messages re-stamped", o, d);
    check_common(o, d);
    INFO(o.log);
    CHECK(o.status.clock_jumps == 1);
    CHECK(o.status.channels[0].accepted == kScans);
    CHECK(o.status.channels[1].accepted == kScans);
    CHECK(o.status.scans_lost_estimate == 0);  // a clock step is not a gap of 36,000 scans
    CHECK(o.status.odometry_resets == 0);
    CHECK(o.accepted.size() >= d.clean.accepted.size() / 2);
  }

  SECTION("every scan and pose duplicated") {
    const FaultFiles files(d, "duplicated");
    const std::string& faulty = files.drive;
    const std::string& out = files.out;
    const FaultResult f = loopd::test::duplicate_messages(d.drive, faulty, {channels::kScan, channels::kPose});
    INFO(f.error);
    REQUIRE(f.ok);
    REQUIRE(f.affected == 2 * kScans);
    const Outcome o = replay(faulty, out);
    print_row("duplicated", std::to_string(f.affected) + " duplicates", o, d);
    check_common(o, d);
    INFO(o.log);
    CHECK(o.status.channels[0].received == 2 * kScans);
    CHECK(o.status.invalid_scans == kScans);
    CHECK(rejected(o.status, 1) == kScans);  // the pose duplicates
    CHECK(o.status.channels[0].accepted == kScans);
    CHECK(o.status.scans_lost_estimate == 0);
    CHECK(o.status.clock_jumps == 0);
    // The first copies are the clean drive: the same decisions.
    CHECK(o.accepted == d.clean.accepted);
  }

  SECTION("neighbouring scans reordered") {
    const FaultFiles files(d, "scans_reordered");
    const std::string& faulty = files.drive;
    const std::string& out = files.out;
    // At 10 Hz neighbouring scans are 100 ms apart, so a swap delivers the newer scan 100 ms early; the older one
    // then arrives late and is rejected as out of order.
    const FaultResult f = loopd::test::swap_neighbours(d.drive, faulty, channels::kScan, 0.1, 150'000, 7);
    INFO(f.error);
    REQUIRE(f.ok);
    REQUIRE(f.affected > 0);
    const Outcome o = replay(faulty, out);
    print_row("reordered", std::to_string(f.affected) + " scan pairs swapped", o, d);
    check_common(o, d);
    INFO(o.log);
    CHECK(o.status.channels[0].received == kScans);
    CHECK(o.status.invalid_scans == f.affected);
    // Every scan reached loopd: a late one is rejected (invalid) but not also counted as lost (the early scan's
    // 200 ms interval looked like a gap of one lost scan until the late one arrived).
    CHECK(o.status.scans_lost_estimate == 0);
    CHECK(o.status.clock_jumps == 0);
    CHECK(o.status.odometry_resets == 0);
  }

  SECTION("neighbouring poses reordered") {
    const FaultFiles files(d, "poses_reordered");
    const std::string& faulty = files.drive;
    const std::string& out = files.out;
    const FaultResult f = loopd::test::swap_neighbours(d.drive, faulty, channels::kPose, 0.1, 150'000, 8);
    INFO(f.error);
    REQUIRE(f.ok);
    REQUIRE(f.affected > 0);
    const Outcome o = replay(faulty, out);
    print_row("poses reordered", std::to_string(f.affected) + " pose pairs swapped", o, d);
    check_common(o, d);
    INFO(o.log);
    CHECK(o.status.channels[1].received == kScans);
    CHECK(rejected(o.status, 1) == f.affected);
    CHECK(o.status.scans_lost_estimate == 0);
    CHECK(o.status.clock_jumps == 0);
    CHECK(o.status.odometry_resets == 0);
  }

  SECTION("every scan arrives before its pose") {
    const FaultFiles files(d, "scan_before_pose");
    const FaultResult f = loopd::test::deliver_before(d.drive, files.drive, channels::kScan, channels::kPose);
    INFO(f.error);
    REQUIRE(f.ok);
    REQUIRE(f.affected == kScans);
    const Outcome o = replay(files.drive, files.out);
    print_row("scan before pose", std::to_string(f.affected) + " scans moved ahead", o, d);
    check_common(o, d);
    INFO(o.log);
    // A scan waits for its pose: nothing rejected or dropped, the clean drive's decisions.
    CHECK(o.status.channels[0].accepted == kScans);
    CHECK(o.status.channels[0].dropped == 0);
    CHECK(o.status.channels[1].accepted == kScans);
    CHECK(o.status.invalid_scans == 0);
    CHECK(o.status.scans_lost_estimate == 0);
    CHECK(o.accepted == d.clean.accepted);
  }

  SECTION("the lidar changes mid-drive: VLP-16 -> HDL-32E") {
    const FaultFiles files(d, "sensor_change");
    const std::string& faulty = files.drive;
    const std::string& out = files.out;
    const std::string& other = d.hdl32_drive();
    REQUIRE(!other.empty());
    const FaultResult f = loopd::test::splice_channel(d.drive, other, faulty, channels::kScan, d.middle_utime());
    INFO(f.error);
    REQUIRE(f.ok);
    REQUIRE(f.affected == kScans - kMiddle);
    const Outcome o = replay(faulty, out);
    print_row("sensor change", std::to_string(f.affected) + " scans from an HDL-32E", o, d);
    check_common(o, d);
    INFO(o.log);
    CHECK(o.status.sensor_changes == 1);
    CHECK(o.status.channels[0].accepted == kScans);
    CHECK(o.status.scans_lost_estimate == 0);
    CHECK(o.status.clock_jumps == 0);
    CHECK(o.status.odometry_resets == 0);
  }

  SECTION("odometry restarts at identity mid-drive") {
    const FaultFiles files(d, "odometry_reset");
    const std::string& faulty = files.drive;
    const std::string& out = files.out;
    const FaultResult f = loopd::test::reset_odometry(d.drive, faulty, channels::kPose, d.middle_utime());
    INFO(f.error);
    REQUIRE(f.ok);
    REQUIRE(f.affected == kScans - kMiddle);
    const Outcome o = replay(faulty, out);
    print_row("odometry reset", std::to_string(f.affected) + " poses re-expressed", o, d);
    check_common(o, d);
    INFO(o.log);
    CHECK(o.status.odometry_resets == 1);
    CHECK(o.status.channels[1].accepted == kScans);
    CHECK(o.status.clock_jumps == 0);
    CHECK(o.status.scans_lost_estimate == 0);
    // The trajectory continues from the pose before the restart, so the revisit is still recognised.
    CHECK(o.accepted.size() >= d.clean.accepted.size() / 2);
  }
}

TEST_CASE("fault matrix, live: a 5x scan flood and a lossy drive beside lcm-logplayer", "[live]") {
  if (loopd::test::run_quiet("ip route get 239.255.76.67 | grep -q 'dev lo'") != 0) {
    WARN(
        "skipped: multicast 239.255.76.0/24 is not routed through loopback (as root: ip link set lo multicast on; "
        "ip route add 239.255.76.0/24 dev lo)");
    return;
  }
  SharedDrive& d = shared_drive();
  INFO(d.error);
  REQUIRE(d.error.empty());

  SECTION("scan flood: the drive played at 5x the sensor rate") {
    const FaultFiles files(d, "live_flood");
    const Outcome o = live(d.drive, 5.0, files.out);
    print_row("live flood 5x", "340 scans at 50 Hz", o, d);
    check_common(o, d);
    // Whatever the kernel lost is estimated from the scan-rate gaps: received + estimated loss covers the drive.
    const std::int64_t received = o.status.channels[0].received;
    const std::int64_t truly_lost = kScans - received;
    CHECK(received > 0);
    CHECK(o.status.scans_lost_estimate >= static_cast<std::int64_t>(0.7 * static_cast<double>(truly_lost)) - 2);
    CHECK(o.status.scans_lost_estimate <= static_cast<std::int64_t>(1.3 * static_cast<double>(truly_lost)) + 2);
    // Data time running 5x faster than the wall clock is not a clock jump, and nothing else happened.
    CHECK(o.status.clock_jumps == 0);
    CHECK(o.status.odometry_resets == 0);
    CHECK(o.status.sensor_changes == 0);
  }

  // At 2x (20 scans a second), not 1x: the loss is told from the data's scan-rate gaps, whatever the playing speed
  // (test_live plays a drive at 1x), and the test holds both cores for half as long.
  SECTION("10 % of the scans dropped, played at 2x") {
    const FaultFiles files(d, "live_drop10");
    const FaultResult f = loopd::test::drop_messages(d.drive, files.drive, channels::kScan, 0.1, 12);
    INFO(f.error);
    REQUIRE(f.ok);
    const Outcome o = live(files.drive, 2.0, files.out);
    print_row("live drop 10% 2x", std::to_string(f.affected) + " scans dropped", o, d);
    check_common(o, d);
    // The truth: scans not in the file plus any the kernel lost on the way.
    const std::int64_t truly_lost = kScans - o.status.channels[0].received;
    CHECK(truly_lost >= f.affected);
    CHECK(o.status.scans_lost_estimate >= static_cast<std::int64_t>(0.7 * static_cast<double>(truly_lost)));
    CHECK(o.status.scans_lost_estimate <= static_cast<std::int64_t>(1.3 * static_cast<double>(truly_lost)));
    CHECK(o.status.clock_jumps == 0);
    CHECK(o.status.odometry_resets == 0);
    CHECK(o.status.sensor_changes == 0);
  }
}
