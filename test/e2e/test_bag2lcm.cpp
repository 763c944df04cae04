// bag2lcm end to end: a simulated drive (loopd-sim) is written as a ROS 1 bag by the ROS 1 Python tools
// (test/e2e/drive_to_bag.py: four PointCloud2 layouts, odometry on /odom and /tf in the base frame, a two-hop static
// TF to the lidar, ground truth as PoseStamped, lz4 and bz2 chunks), converted back with bag2lcm and compared with the
// drive: same scans point for point, same poses to 1e-6 (the static TF undone), and loopd --replay decides the same.
// Damaged bags fail with an error that names the problem. Skipped (WARN) without python3-rosbag or without bag2lcm.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "lcm_log.hpp"
#include "message_convert.hpp"
#include "support/process.hpp"
#include "support/run_command.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {

const std::string kBin = LOOPD_BINARY_DIR;
const std::string kBag2lcm = kBin + "/tools/bag2lcm/bag2lcm";
const std::string kPython = "/usr/bin/python3";  // Debian's: python3-rosbag installs for it (not for a pyenv python3)
const std::string kScript = std::string(LOOPD_SOURCE_DIR) + "/test/e2e/drive_to_bag.py";

/// Why the bag tests cannot run here ("" when they can).
std::string missing_tools() {
  if (!fs::exists(kBag2lcm)) return "bag2lcm is not built (Debian's ROS 1 bag packages were missing at configure time)";
  if (test::run_quiet(kPython + " -c 'import rosbag, sensor_msgs.msg, nav_msgs.msg, tf2_msgs.msg, geometry_msgs.msg'") != 0)
    return "python3-rosbag, python3-sensor-msgs, python3-nav-msgs, python3-tf2-msgs or python3-geometry-msgs is not installed";
  return "";
}

#define LOOPD_REQUIRE_BAG_TOOLS()                              \
  if (const std::string why = missing_tools(); !why.empty()) { \
    WARN("skipped: " << why);                                  \
    return;                                                    \
  }

struct TempDir {
  fs::path dir = fs::temp_directory_path() / ("loopd_bag2lcm_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(dir); }
  ~TempDir() { fs::remove_all(dir); }
  std::string operator/(const std::string& name) const { return (dir / name).string(); }
};

/// The events of a drive log by channel, decoded, with their log timestamps.
struct Drive {
  std::vector<std::pair<std::int64_t, point_cloud_t>> scans;
  std::map<std::string, std::vector<std::pair<std::int64_t, pose_t>>> poses;  ///< ODOMETRY_POSE, GROUND_TRUTH_POSE
};

Drive read_drive(const std::string& path) {
  Drive d;
  LogReader reader;
  std::string error;
  REQUIRE(reader.open(path, &error));
  LogEvent ev;
  while (reader.next(&ev)) {
    if (ev.channel == channels::kScan) {
      point_cloud_t m;
      REQUIRE(LogReader::decode(ev, &m));
      d.scans.emplace_back(ev.timestamp, m);
    } else {
      pose_t p;
      REQUIRE(LogReader::decode(ev, &p));
      d.poses[ev.channel].emplace_back(ev.timestamp, p);
    }
  }
  CHECK(reader.problems().empty());
  return d;
}

void check_same_scans(const Drive& original, const Drive& converted) {
  REQUIRE(converted.scans.size() == original.scans.size());
  for (std::size_t i = 0; i < original.scans.size(); ++i) {
    const point_cloud_t &a = original.scans[i].second, &b = converted.scans[i].second;
    INFO("scan " << i);
    CHECK(converted.scans[i].first == original.scans[i].first);
    CHECK(b.utime == a.utime);
    CHECK(b.seq == a.seq);
    CHECK(b.frame == a.frame);
    REQUIRE(b.num_points == a.num_points);
    CHECK(b.x == a.x);  // float32 -> float32 or float64 -> float32: exact
    CHECK(b.y == a.y);
    CHECK(b.z == a.z);
    CHECK(b.intensity == a.intensity);
    CHECK(b.num_ring_indices == a.num_ring_indices);
    CHECK(b.ring == a.ring);
    CHECK(b.num_rings == a.num_rings);
    // Per-point times through each layout's unit: float32 s exact, int32 ns to 0.5 ns, float64 s since the epoch to
    // its 0.24 us resolution at 1.7e9 s.
    REQUIRE(b.num_point_times == a.num_point_times);
    float worst = 0.f;
    for (std::size_t k = 0; k < a.time_offset.size(); ++k) worst = std::max(worst, std::abs(a.time_offset[k] - b.time_offset[k]));
    CHECK(worst < 1e-6f);
  }
}

/// Poses of one channel: same stamps, seq and log times; positions and orientations within 1e-6.
void check_same_poses(const Drive& original, const Drive& converted, const std::string& channel) {
  const auto& a = original.poses.at(channel);
  REQUIRE(converted.poses.count(channel));
  const auto& b = converted.poses.at(channel);
  REQUIRE(b.size() == a.size());
  double worst_position = 0.0, worst_orientation = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    INFO(channel << " pose " << i);
    CHECK(b[i].first == a[i].first);
    CHECK(b[i].second.utime == a[i].second.utime);
    CHECK(b[i].second.seq == a[i].second.seq);
    double dot = 0.0;
    for (int k = 0; k < 4; ++k) dot += a[i].second.orientation[k] * b[i].second.orientation[k];
    const double sign = dot < 0.0 ? -1.0 : 1.0;  // q and -q are one rotation
    for (int k = 0; k < 3; ++k) worst_position = std::max(worst_position, std::abs(a[i].second.position[k] - b[i].second.position[k]));
    for (int k = 0; k < 4; ++k)
      worst_orientation = std::max(worst_orientation, std::abs(a[i].second.orientation[k] - sign * b[i].second.orientation[k]));
    CHECK(b[i].second.residual == 0.0);  // a ROS Odometry has no residual: 0, "unknown"
  }
  INFO(channel);
  CHECK(worst_position < 1e-6);
  CHECK(worst_orientation < 1e-6);
}

/// The drive with the odometry residuals set to 0, as a ROS Odometry (which has none) gives them.
void write_without_residuals(const std::string& in, const std::string& out) {
  LogReader reader;
  LogWriter writer;
  std::string error;
  REQUIRE(reader.open(in, &error));
  REQUIRE(writer.open(out, &error));
  LogEvent ev;
  while (reader.next(&ev)) {
    pose_t p;
    if (ev.channel == channels::kPose && LogReader::decode(ev, &p)) {
      p.residual = 0.0;
      REQUIRE(writer.write_message(ev.channel, ev.timestamp, p));
    } else {
      REQUIRE(writer.write(ev.channel, ev.timestamp, ev.data.data(), ev.data.size()));
    }
  }
  writer.close();
}

/// Runs a tool with --json; its exit status must be `expected_rc` (-1: 0 or 1, as loopd-compare's identical or not).
nlohmann::json run_json(const std::string& command, int expected_rc) {
  int rc = 0;
  const std::string log = test::run_command(command, &rc);
  INFO(command << "\n" << log);
  if (expected_rc < 0) {
    REQUIRE((rc == 0 || rc == 1));
  } else {
    REQUIRE(rc == expected_rc);
  }
  return nlohmann::json::parse(test::last_line(log));
}

const nlohmann::json& topic(const nlohmann::json& j, const std::string& name) {
  for (const auto& t : j.at("topics"))
    if (t.at("topic") == name) return t;
  FAIL("no topic " << name << " in " << j.dump());
  return j;
}

std::string replay(const std::string& drive, const std::string& out) {
  int rc = 0;
  const std::string log = test::run_command(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive + " --output " + out, &rc);
  INFO(log);
  REQUIRE(rc == 0);
  return out;
}

}  // namespace

TEST_CASE("bag2lcm turns a ROS 1 bag of a simulated drive back into the same drive", "[bag2lcm][e2e]") {
  LOOPD_REQUIRE_BAG_TOOLS();
  TempDir tmp;
  const std::string drive = tmp / "drive.lcmlog";
  int rc = 0;
  // 40 VLP-16 scans, 8 m apart: one lap of the block and a revisit of its start (loops for loopd to decide).
  std::string log = test::run_command(
      kBin + "/tools/loopd-sim/loopd-sim --out " + drive + " --sensor vlp16 --scans 40 --seed 11 --route block --rate 5 --speed 40 --quiet", &rc);
  INFO(log);
  REQUIRE(rc == 0);
  log = test::run_command(kPython + " " + kScript + " " + drive + " " + (tmp / "lz4.bag") + " --compression lz4 --bad-messages", &rc);
  INFO(log);
  REQUIRE(rc == 0);
  log = test::run_command(kPython + " " + kScript + " " + drive + " " + (tmp / "bz2.bag") + " --compression bz2", &rc);
  INFO(log);
  REQUIRE(rc == 0);
  const Drive original = read_drive(drive);
  REQUIRE(original.scans.size() == 40);

  // Odometry from /odom, ground truth from /ground_truth (PoseStamped of base_link), both moved into the lidar frame
  // by the static chain base_link -> mount -> lidar.
  const std::string odom_out = tmp / "odom.lcmlog";
  const nlohmann::json j = run_json(
      kBag2lcm + " " + (tmp / "lz4.bag") + " --out " + odom_out + " --cloud-topic /points --odom-topic /odom --gt-topic /ground_truth --quiet --json",
      0);
  CHECK(j.at("ok") == true);
  CHECK(j.at("scans") == 40);
  CHECK(j.at("poses") == 40);
  CHECK(j.at("ground_truth") == 40);
  CHECK(j.at("sensor_frame") == "lidar");
  CHECK(j.at("base_frame") == "base_link");
  CHECK(j.at("num_rings") == 16);
  CHECK(j.at("points_nonfinite").get<int>() > 0);  // the organised layout's NaN cells
  std::int64_t with_times = 0;
  for (const auto& [t, scan] : original.scans) with_times += scan.num_point_times > 0 ? 1 : 0;
  CHECK(j.at("scans_with_times") == with_times);
  const auto& points = topic(j, "/points");
  CHECK(points.at("in") == 41);
  CHECK(points.at("out") == 40);
  CHECK(points.at("skipped_by_reason").at("bad layout").at("count") == 1);
  CHECK(points.at("skipped_by_reason").at("bad layout").at("first") == "message 3: field 'x' missing (fields: y, z)");
  const auto& odom = topic(j, "/odom");
  CHECK(odom.at("in") == 41);
  CHECK(odom.at("skipped_by_reason").at("bad pose").at("count") == 1);
  CHECK(topic(j, "/ground_truth").at("type") == "geometry_msgs/PoseStamped");
  CHECK(topic(j, "/tf_static").at("in") == 1);
  const Drive converted = read_drive(odom_out);
  check_same_scans(original, converted);
  check_same_poses(original, converted, channels::kPose);
  check_same_poses(original, converted, channels::kGroundTruth);

  // Odometry from /tf (odom -> base_link; base_link -> wheel moves too, and triggers nothing), bz2 chunks.
  const std::string tf_out = tmp / "tf.lcmlog";
  const nlohmann::json t = run_json(
      kBag2lcm + " " + (tmp / "bz2.bag") + " --out " + tf_out + " --cloud-topic /points --tf odom base_link --gt-topic /ground_truth --quiet --json",
      0);
  CHECK(t.at("poses") == 40);
  CHECK(topic(t, "/tf").at("in") == 80);
  CHECK(topic(t, "/tf").at("unused") == 40);
  CHECK(topic(t, "/tf").at("skipped") == 0);
  const Drive from_tf = read_drive(tf_out);
  check_same_scans(original, from_tf);
  check_same_poses(original, from_tf, channels::kPose);

  // loopd decides the same on the converted drive as on the drive itself. The bag's odometry has no residuals (ROS
  // has no such field: bag2lcm writes 0, "unknown"); the residuals weight the trajectory correction, so the
  // comparison that must be IDENTICAL is with the drive's residuals set to 0. With them, the decisions still agree.
  // loopd deskews the scans with their per-point times, which the bag carries to 1 us: the two runs' transforms then
  // differ by a few 1e-6 m (7.4e-6 m measured) and, as this drive turns at hundreds of deg/s in its corners (40 m/s),
  // where 1 us moves a point's bearing by ~1e-4 deg, by a few 1e-5 deg (6.3e-5 deg measured): IDENTICAL is judged at
  // 1e-5 m and 1e-4 deg.
  const std::string no_residuals = tmp / "no_residuals.lcmlog";
  write_without_residuals(drive, no_residuals);
  const std::string out_converted = replay(odom_out, tmp / "out_converted.lcmlog");
  const std::string compare = kBin + "/tools/loopd-compare/loopd-compare --json ";
  const nlohmann::json same =
      run_json(compare + "--tolerance-m 1e-5 --tolerance-deg 1e-4 " + replay(no_residuals, tmp / "out_reference.lcmlog") + " " + out_converted, 0);
  CHECK(same.at("identical") == true);
  CHECK(same.at("events_a").get<int>() >= 3);
  CHECK(same.at("accepted_both").get<int>() >= 1);
  const nlohmann::json decisions = run_json(compare + replay(drive, tmp / "out_original.lcmlog") + " " + out_converted, -1);
  CHECK(decisions.at("decisions_differ") == 0);
  CHECK(decisions.at("accepted_only_a") == 0);
  CHECK(decisions.at("accepted_only_b") == 0);
  CHECK(decisions.at("decided_only_a") == 0);
  CHECK(decisions.at("decided_only_b") == 0);
  CHECK(decisions.at("accepted_both") == same.at("accepted_both"));
}

/// The gyro samples of a drive log, by utime.
std::map<std::int64_t, imu_t> read_gyro(const std::string& path) {
  std::map<std::int64_t, imu_t> out;
  LogReader reader;
  std::string error;
  REQUIRE(reader.open(path, &error));
  LogEvent ev;
  while (reader.next(&ev)) {
    imu_t m;
    if (ev.channel == channels::kImu && LogReader::decode(ev, &m)) out[m.utime] = m;
  }
  return out;
}

TEST_CASE("bag2lcm turns a gyro's sensor_msgs/Imu into imu_t in the scans' frame", "[bag2lcm][e2e]") {
  LOOPD_REQUIRE_BAG_TOOLS();
  TempDir tmp;
  const std::string drive = tmp / "drive.lcmlog", bag = tmp / "imu.bag", out = tmp / "out.lcmlog";
  int rc = 0;
  std::string log = test::run_command(
      kBin + "/tools/loopd-sim/loopd-sim --out " + drive + " --sensor vlp16 --scans 10 --seed 11 --route block --imu-rate 200 --quiet", &rc);
  INFO(log);
  REQUIRE(rc == 0);
  // The bag's IMU is mounted upside down and turned on base_link (/tf_static base_link -> imu): its samples are in
  // that frame, and bag2lcm turns them back into the lidar's through base_link -> mount -> lidar.
  log = test::run_command(kPython + " " + kScript + " " + drive + " " + bag, &rc);
  INFO(log);
  REQUIRE(rc == 0);
  const nlohmann::json j =
      run_json(kBag2lcm + " " + bag + " --out " + out + " --cloud-topic /points --odom-topic /odom --imu-topic /imu --quiet --json", 0);
  CHECK(topic(j, "/imu").at("in") == 200);
  CHECK(topic(j, "/imu").at("out") == 200);
  CHECK(topic(j, "/imu").at("channel") == "IMU");
  const auto original = read_gyro(drive), converted = read_gyro(out);
  REQUIRE(original.size() == 200);
  REQUIRE(converted.size() == 200);
  double largest = 0.0, worst = 0.0;
  for (const auto& [utime, m] : original) {
    const auto it = converted.find(utime);
    REQUIRE(it != converted.end());
    for (int a = 0; a < 3; ++a) {
      largest = std::max(largest, std::abs(m.angular_velocity[a]));
      worst = std::max(worst, std::abs(m.angular_velocity[a] - it->second.angular_velocity[a]));
    }
  }
  CAPTURE(largest, worst);
  CHECK(largest > 1e-3);  // the gyro measured something (noise at least)
  CHECK(worst < 1e-12);
  // Without the IMU's transform the samples are written as measured, and the report says so.
  const nlohmann::json unrotated =
      run_json(kBag2lcm + " " + bag + " --out " + (tmp / "raw.lcmlog") +
                   " --cloud-topic /points --odom-topic /odom --imu-topic /imu --tf-static-topic /none --base-frame lidar "
                   "--quiet --json",
               0);
  CHECK(topic(unrotated, "/imu").at("out") == 200);
  CHECK(topic(unrotated, "/imu").at("written_with_notes").at("in the IMU's frame").at("count") == 200);
  const nlohmann::json missing = run_json(
      kBag2lcm + " " + bag + " --out " + (tmp / "x.lcmlog") + " --cloud-topic /points --odom-topic /odom --imu-topic /nope --quiet --json", 2);
  CHECK(missing.at("error").get<std::string>().find("topic /nope is not in") != std::string::npos);
}

TEST_CASE("bag2lcm refuses damaged bags with an error that names the problem, and never crashes", "[bag2lcm][e2e]") {
  LOOPD_REQUIRE_BAG_TOOLS();
  TempDir tmp;
  const std::string drive = tmp / "drive.lcmlog", bag = tmp / "drive.bag", out = tmp / "out.lcmlog";
  int rc = 0;
  std::string log = test::run_command(kBin + "/tools/loopd-sim/loopd-sim --out " + drive + " --sensor vlp16 --scans 4 --seed 3 --quiet", &rc);
  INFO(log);
  REQUIRE(rc == 0);
  log = test::run_command(kPython + " " + kScript + " " + drive + " " + bag + " --compression lz4 --corrupt-index " + (tmp / "bad_index.bag"), &rc);
  INFO(log);
  REQUIRE(rc == 0);
  std::ifstream in(bag, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto write = [&](const std::string& name, const std::string& content) {
    std::ofstream(tmp / name, std::ios::binary) << content;
    return tmp / name;
  };
  // Runs bag2lcm on `file`: exit status 2 (bad input), no output file, and the error (last stderr line, and the JSON)
  // says `what`.
  auto refuses = [&](const std::string& file, const std::string& args, const std::string& what) {
    const std::string command = kBag2lcm + " " + file + " --out " + out + " --quiet --json " + args;
    const std::string text = test::run_command(command, &rc);
    INFO(command << "\n" << text);
    CHECK(rc == 2);  // bad input, not a signal (-1)
    CHECK_FALSE(fs::exists(out));
    const nlohmann::json j = nlohmann::json::parse(test::last_line(text));
    CHECK(j.at("ok") == false);
    CHECK_THAT(j.at("error").get<std::string>(), Catch::Contains(what));
    CHECK_THAT(text, Catch::Contains("bag2lcm: "));
  };
  const std::string odom = "--cloud-topic /points --odom-topic /odom";
  run_json(kBag2lcm + " " + bag + " --out " + out + " --quiet --json " + odom, 0);  // the intact bag converts
  fs::remove(out);
  refuses(write("half.bag", bytes.substr(0, bytes.size() / 2)), odom, "truncated: the file has");
  refuses(write("cut_index.bag", bytes.substr(0, bytes.size() - 10)), odom, "rosbag_storage cannot open it");
  refuses(write("text.bag", "just text\n"), odom, "not a ROS 1 bag");
  refuses(write("empty.bag", ""), odom, "not a ROS 1 bag");
  std::string unindexed = bytes;
  const std::size_t index_pos = unindexed.find("index_pos=");
  REQUIRE(index_pos != std::string::npos);
  unindexed.replace(index_pos + 10, 8, std::string(8, '\0'));
  refuses(write("unindexed.bag", unindexed), odom, "the bag has no index");
  std::string unknown = bytes;
  for (std::size_t p = 0; (p = unknown.find("compression=lz4", p)) != std::string::npos; ++p) unknown.replace(p, 15, "compression=xz4");
  refuses(write("unknown_compression.bag", unknown), odom, "topic /tf_static message 0: cannot read it from the bag: Unknown compression: xz4");
  refuses(bag, "--cloud-topic /points --odom-topic /ground_truth",
          "topic /ground_truth message 0: geometry_msgs/PoseStamped, expected nav_msgs/Odometry");
  refuses(bag, "--cloud-topic /odom --odom-topic /odom2", "topic /odom2 is not in");
  refuses(bag, "--cloud-topic /odom --odom-topic /ground_truth", "topic /odom message 0: nav_msgs/Odometry, expected sensor_msgs/PointCloud2");
  refuses(bag, "--cloud-topic /points --odom-topic /odom --base-frame nowhere", "no transform between the odometry's frame 'nowhere'");
  // A damaged index entry makes rosbag_storage read outside its buffer (SIGSEGV): reported, not a crash of bag2lcm.
  refuses(tmp / "bad_index.bag", odom, "message 0: ");
  log = test::run_command(kBag2lcm + " " + bag + " --out " + out + " --quiet --cloud-topic /points", &rc);
  CHECK(rc == 2);  // neither --odom-topic nor --tf
}
