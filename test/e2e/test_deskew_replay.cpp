// Deskew end to end: loopd-sim writes a small skewed drive (per-point times, scans stamped at the sweep's end) and
// the same drive without times; loopd replays each with `deskew.enabled` true (the default) and false. The switch
// works through the config, status_t counts what deskew did, and scans without times come out identical.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <loopd/status_t.hpp>

#include "lcm_log.hpp"
#include "message_convert.hpp"
#include "support/run_command.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {
const std::string kBin = LOOPD_BINARY_DIR;

struct Replay {
  status_t status{};
  nlohmann::json eval;
  std::string log;
};

/// loopd --replay `drive` with `config`, its last status_t and loopd-eval's JSON.
Replay replay(const std::string& drive, const std::string& config, const std::string& out) {
  Replay r;
  int rc = 0;
  r.log = loopd::test::run_command(kBin + "/daemon/loopd --sensor vlp16 --config " + config + " --replay " + drive + " --output " + out, &rc);
  INFO(r.log);
  REQUIRE(rc == 0);
  LogReader reader;
  std::string error;
  REQUIRE(reader.open(out, &error));
  LogEvent ev;
  while (reader.next(&ev))
    if (ev.channel == channels::kStatus) REQUIRE(LogReader::decode(ev, &r.status));
  const std::string eval = loopd::test::run_command(kBin + "/tools/loopd-eval/loopd-eval --json --quiet --drive " + drive + " --results " + out, &rc);
  INFO(eval);
  REQUIRE(rc == 0);
  r.eval = nlohmann::json::parse(loopd::test::last_line(eval));
  return r;
}

/// loopd-compare's exit status: 0 identical (to `tolerance` m and deg), 1 different.
int compare(const std::string& a, const std::string& b, const std::string& tolerance = "1e-6") {
  int rc = 0;
  loopd::test::run_command(
      kBin + "/tools/loopd-compare/loopd-compare --tolerance-m " + tolerance + " --tolerance-deg " + tolerance + " " + a + " " + b, &rc);
  return rc;
}
}  // namespace

TEST_CASE("deskew.enabled switches motion compensation of a replayed drive, scans without times are untouched") {
  const fs::path dir = fs::temp_directory_path() / ("loopd_deskew_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const auto path = [&dir](const std::string& name) { return (dir / name).string(); };
  std::ofstream(path("on.yaml")) << "deskew:\n  enabled: true\n";
  std::ofstream(path("off.yaml")) << "deskew:\n  enabled: false\n";
  std::ofstream(path("odometry.yaml")) << "deskew:\n  from_scans: false\n";
  int rc = 0;
  const std::string sim = kBin + "/tools/loopd-sim/loopd-sim --sensor vlp16 --scans 340 --seed 11 --route block --quiet";
  std::string log = loopd::test::run_command(sim + " --out " + path("skewed.lcmlog"), &rc);
  REQUIRE(rc == 0);
  log = loopd::test::run_command(sim + " --no-point-times --out " + path("untimed.lcmlog"), &rc);
  REQUIRE(rc == 0);

  const Replay on = replay(path("skewed.lcmlog"), path("on.yaml"), path("on.lcmlog"));
  const Replay off = replay(path("skewed.lcmlog"), path("off.yaml"), path("off.lcmlog"));
  // Every keyframe is deskewed. The first scan is none: its sweep began before the first pose (the next scan,
  // measured throughout, is the first keyframe), so the two runs may differ by that one.
  CHECK(std::abs(on.status.keyframes - off.status.keyframes) <= 1);
  CHECK(on.status.keyframes_deskewed == on.status.keyframes);
  CHECK(on.status.deskew_skipped == 0);
  CHECK(on.log.find("loopd: deskew: " + std::to_string(on.status.keyframes_deskewed) + " keyframes deskewed") != std::string::npos);
  // The preset is the drive's sensor: its layout is read before deskew moves the points (deskewed, the near rings
  // spread by degrees and the preset check warned on every skewed drive).
  CHECK(on.log.find("WARNING") == std::string::npos);
  CHECK(on.log.find("16 rings between -15.0 and +15.0 deg") != std::string::npos);
  CHECK(off.status.keyframes_deskewed == 0);
  CHECK(off.status.deskew_skipped == 0);
  CHECK(off.log.find("loopd: deskew:") == std::string::npos);
  CHECK(compare(path("on.lcmlog"), path("off.lcmlog")) == 1);  // other scans, other decisions
  // Every deskewed loop agrees with ground truth, and the worst loop rotations shrink (they come from turns: scans of
  // one place skewed differently). The median can grow: same-direction revisits are skewed alike, and deskew adds
  // each scan's own odometry-step noise (docs/accuracy.md).
  CHECK(on.eval["closure_precision"].get<double>() == 1.0);
  // No revisit is lost (the accepted count itself may differ by a loop either way: the keyframes differ).
  CHECK(on.eval["closure_recall"].get<double>() >= off.eval["closure_recall"].get<double>());
  CHECK(on.eval["loop_rotation_error_p95_deg"].get<double>() < off.eval["loop_rotation_error_p95_deg"].get<double>());

  // The sweeps' motion measured by the scans (deskew.from_scans, the default) instead of the odometry's 10 Hz steps:
  // the odometry's step noise no longer bends the scans, and the revisits' loops come out within centimetres.
  const Replay odometry = replay(path("skewed.lcmlog"), path("odometry.yaml"), path("odometry.lcmlog"));
  INFO("loop error median / p95 / max: from scans "
       << on.eval["loop_translation_error_median"] << " / " << on.eval["loop_translation_error_p95"] << " / " << on.eval["loop_translation_error_max"]
       << ", odometry " << odometry.eval["loop_translation_error_median"] << " / " << odometry.eval["loop_translation_error_p95"] << " / "
       << odometry.eval["loop_translation_error_max"]);
  CHECK(on.log.find("sweeps with the motion their scans measured") != std::string::npos);
  CHECK(odometry.log.find("sweeps with the motion their scans measured") == std::string::npos);
  CHECK(odometry.eval["closure_precision"].get<double>() == 1.0);
  CHECK(on.eval["loop_translation_error_median"].get<double>() < 0.02);
  CHECK(on.eval["loop_translation_error_p95"].get<double>() < 0.08);
  CHECK(on.eval["loop_translation_error_median"].get<double>() < 0.6 * odometry.eval["loop_translation_error_median"].get<double>());
  CHECK(on.eval["loop_translation_error_p95"].get<double>() < 0.8 * odometry.eval["loop_translation_error_p95"].get<double>());
  // The final trajectory (the run's last full solve) within a bound of ground truth: ATE 0.585 -> 0.077 m measured with
  // the keyframe steps measured by the scans (correction.steps, the default); with the odometry's steps 0.37 m, the
  // first lap's own odometry wander (scale error, degraded stretches) that no loop sees (docs/accuracy.md, "Where the
  // loop error and the ATE come from").
  std::ofstream(path("no_steps.yaml")) << "correction:\n  steps:\n    enabled: false\n";
  const Replay no_steps = replay(path("skewed.lcmlog"), path("no_steps.yaml"), path("no_steps.lcmlog"));
  INFO("ATE after: measured steps " << on.eval["ate_after"] << ", odometry steps " << no_steps.eval["ate_after"]);
  CHECK(on.log.find("keyframe steps measured by the scans") != std::string::npos);
  CHECK(no_steps.log.find("keyframe steps measured by the scans") == std::string::npos);
  CHECK(on.eval["ate_after"].get<double>() < 0.12);
  CHECK(on.eval["ate_after"].get<double>() < 0.4 * no_steps.eval["ate_after"].get<double>());
  CHECK(no_steps.eval["closure_precision"].get<double>() == 1.0);

  // Without per-point times deskew never runs: the same decisions and trajectory, to the bit, as with it off.
  const Replay untimed_on = replay(path("untimed.lcmlog"), path("on.yaml"), path("untimed_on.lcmlog"));
  const Replay untimed_off = replay(path("untimed.lcmlog"), path("off.yaml"), path("untimed_off.lcmlog"));
  CHECK(untimed_on.status.keyframes_deskewed == 0);
  CHECK(untimed_on.status.deskew_skipped == 0);
  CHECK(compare(path("untimed_on.lcmlog"), path("untimed_off.lcmlog"), "0") == 0);
  // Nor are their keyframe steps measured: two skewed scans register short (the demo drive without times: ATE 0.36 ->
  // 0.84 m with them). Declared motion-compensated upstream, they are (here wrongly: the scans are skewed).
  const std::string untimed_steps = std::to_string(untimed_on.status.keyframes - 1) + " (scans that may be skewed";
  INFO(untimed_on.log);
  CHECK(untimed_on.log.find("loopd: steps: 0 keyframe steps measured by the scans") != std::string::npos);
  CHECK(untimed_on.log.find(untimed_steps) != std::string::npos);
  std::ofstream(path("upstream.yaml")) << "deskew:\n  compensated_upstream: true\n";
  const Replay upstream = replay(path("untimed.lcmlog"), path("upstream.yaml"), path("untimed_upstream.lcmlog"));
  CHECK(upstream.log.find("loopd: steps: 0 keyframe") == std::string::npos);
  CHECK(upstream.log.find(", 0 (scans that may be skewed") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("a gyro on IMU bends each keyframe's sweep as the sensor turned, and with imu.enabled false the drive runs as without it") {
  const std::string dir = (fs::temp_directory_path() / ("loopd_test_imu_" + std::to_string(getpid()))).string();
  fs::create_directories(dir);
  const auto path = [&dir](const std::string& name) { return dir + "/" + name; };
  const std::string sim = kBin + "/tools/loopd-sim/loopd-sim --route block --sensor vlp16 --scans 340 --seed 11 --quiet";
  int rc = 0;
  std::string log = loopd::test::run_command(sim + " --imu-rate 200 --out " + path("imu.lcmlog"), &rc);
  INFO(log);
  REQUIRE(rc == 0);
  log = loopd::test::run_command(sim + " --out " + path("plain.lcmlog"), &rc);
  REQUIRE(rc == 0);
  const std::string defaults = path("defaults.yaml"), no_imu = path("no_imu.yaml");
  std::ofstream(defaults) << "deskew:\n  enabled: true\n";
  std::ofstream(no_imu) << "imu:\n  enabled: false\n";

  const Replay gyro = replay(path("imu.lcmlog"), defaults, path("gyro.lcmlog"));
  const Replay plain = replay(path("plain.lcmlog"), defaults, path("plain_out.lcmlog"));
  const Replay ignored = replay(path("imu.lcmlog"), no_imu, path("ignored.lcmlog"));
  // Every sample of the 340 sweeps at 200 Hz was read (status_t's third channel) and most sweeps were bent by it.
  REQUIRE(gyro.status.num_channels == 3);
  CHECK(gyro.status.channels[2].channel == "IMU");
  CHECK(gyro.status.channels[2].accepted == 340 * 20);
  CHECK(gyro.status.channels[2].malformed == 0);
  CHECK(plain.status.num_channels == 2);
  const auto pos = gyro.log.find(" bent as the gyro turned");
  REQUIRE(pos != std::string::npos);
  const auto start = gyro.log.rfind(", ", pos) + 2;
  const int bent = std::stoi(gyro.log.substr(start, pos - start));
  CHECK(bent >= gyro.status.keyframes - 5);
  CHECK(plain.log.find(", 0 bent as the gyro turned, 0 whose gyro disagreed)") != std::string::npos);
  CHECK(gyro.log.find(" 0 whose gyro disagreed") != std::string::npos);
  CHECK(gyro.log.find("WARNING") == std::string::npos);
  // Switched off, the gyro's messages change nothing: the same decisions and trajectory as the drive without them.
  CHECK(compare(path("ignored.lcmlog"), path("plain_out.lcmlog"), "0") == 0);
  CHECK(compare(path("gyro.lcmlog"), path("plain_out.lcmlog")) == 1);
  INFO("gyro: " << gyro.eval.dump() << "\nwithout: " << plain.eval.dump());
  CHECK(gyro.eval["closure_precision"].get<double>() == 1.0);
  CHECK(gyro.eval["accepted"].get<int>() >= plain.eval["accepted"].get<int>() - 1);
  CHECK(gyro.eval["loop_translation_error_median"].get<double>() < 0.02);
  CHECK(gyro.eval["loop_rotation_error_p95_deg"].get<double>() < 0.35);

  // Configured upside down (imu.rpy_deg roll 180: its turns about z come out reversed), the gyro disagrees with the
  // odometry in every turn: said once, those sweeps deskewed without it, no wrong loop.
  const std::string flipped = path("flipped.yaml");
  std::ofstream(flipped) << "imu:\n  rpy_deg: [180, 0, 0]\n";
  const Replay wrong = replay(path("imu.lcmlog"), flipped, path("flipped.lcmlog"));
  INFO(wrong.log);
  const auto first = wrong.log.find("WARNING: over a sweep the gyro on IMU turned");
  CHECK(first != std::string::npos);
  CHECK(wrong.log.find("WARNING", first + 1) == std::string::npos);
  const auto refused_at = wrong.log.find(" whose gyro disagreed");
  REQUIRE(refused_at != std::string::npos);
  const auto refused_start = wrong.log.rfind(", ", refused_at) + 2;
  CHECK(std::stoi(wrong.log.substr(refused_start, refused_at - refused_start)) >= 20);  // the corners' sweeps
  CHECK(wrong.eval["closure_precision"].get<double>() == 1.0);
  CHECK(wrong.eval["loop_translation_error_median"].get<double>() < 0.02);
  fs::remove_all(dir);
}
