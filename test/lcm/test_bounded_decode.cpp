// Bounded decoding of untrusted LCM bytes (issue: one crafted message stopped the daemon) and the damage-tolerant
// log reader.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <unistd.h>

#include "bounded_decode.hpp"
#include "lcm_log.hpp"
#include "message_convert.hpp"
#include "scan_decode.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {

template <typename Msg>
std::vector<std::uint8_t> encode(const Msg& m) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  REQUIRE(m.encode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size()));
  return buf;
}

void put_int32(std::vector<std::uint8_t>* buf, std::size_t at, std::int32_t v) {
  const auto u = static_cast<std::uint32_t>(v);
  for (int i = 0; i < 4; ++i) (*buf)[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(u >> (24 - 8 * i));
}

point_cloud_t small_scan(int n) {
  point_cloud_t m{};
  m.utime = 1000;
  m.seq = 7;
  m.frame = "velodyne";
  m.num_points = n;
  for (int i = 0; i < n; ++i) {
    m.x.push_back(static_cast<float>(i));
    m.y.push_back(1.5f);
    m.z.push_back(-0.5f);
    m.intensity.push_back(10.f);
  }
  m.num_ring_indices = n;
  m.ring.assign(static_cast<std::size_t>(n), 3);
  m.num_rings = 16;
  return m;
}

point_cloud_t with_times(point_cloud_t m) {
  m.num_point_times = m.num_points;
  for (int i = 0; i < m.num_points; ++i) m.time_offset.push_back(-0.1f + 0.02f * static_cast<float>(i));
  return m;
}

/// Big-endian bytes, as LCM writes them, for building messages of older layouts by hand.
struct Bytes {
  std::vector<std::uint8_t> b;
  void be(std::uint64_t v, int width) {
    for (int i = width - 1; i >= 0; --i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void f32(float v) {
    std::uint32_t u;
    std::memcpy(&u, &v, 4);
    be(u, 4);
  }
  void str(const std::string& s) {
    be(s.size() + 1, 4);
    b.insert(b.end(), s.begin(), s.end());
    b.push_back(0);
  }
};

/// A point_cloud_t of version 1 (lcmtypes/point_cloud_t.lcm before num_point_times and time_offset), byte by byte:
/// two points with rings.
std::vector<std::uint8_t> point_cloud_v1_bytes() {
  Bytes m;
  m.be(0x3cbfda035faafa31ull, 8);  // version 1's fingerprint, as lcm-gen computed it for that layout
  m.be(1234567, 8);                // utime
  m.be(42, 8);                     // seq
  m.str("velodyne");
  m.be(2, 4);  // num_points
  for (float v : {1.0f, -2.0f}) m.f32(v);
  for (float v : {0.5f, 3.25f}) m.f32(v);
  for (float v : {-1.5f, 0.0f}) m.f32(v);
  for (float v : {7.0f, 9.0f}) m.f32(v);
  m.be(2, 4);  // num_ring_indices
  m.be(3, 2);
  m.be(15, 2);
  m.be(16, 2);  // num_rings
  return m.b;
}

// Offset of num_points in a point_cloud_t: fingerprint, utime, seq, frame (int32 length + bytes with NUL).
std::size_t num_points_offset(const point_cloud_t& m) { return 8 + 8 + 8 + 4 + m.frame.size() + 1; }

status_t sample_status() {
  status_t s{};
  s.utime = 5;
  s.num_channels = 2;
  for (const char* c : {"LIDAR_SCAN", "ODOMETRY_POSE"}) {
    channel_stats_t cs{};
    cs.channel = c;
    cs.received = 10;
    s.channels.push_back(cs);
  }
  s.device = "cpu";
  s.scans_lost_estimate = 3;
  s.deskew_skipped = 2;
  return s;
}

trajectory_t sample_trajectory(int n) {
  trajectory_t t{};
  t.method = "heuristic+graph";
  t.num_keyframes = n;
  for (int i = 0; i < n; ++i) {
    keyframe_pose_t k{};
    k.id = i;
    k.orientation[0] = 1.0;
    t.keyframes.push_back(k);
    t.keyframe_sessions.push_back(i % 2);
  }
  session_alignment_t a{};
  a.session = 1;
  a.anchored = true;
  a.T_map_session[0] = a.T_map_session[5] = a.T_map_session[10] = a.T_map_session[15] = 1.0;
  a.T_map_session[3] = 12.5;
  a.num_keyframes = n / 2;
  t.sessions.push_back(a);
  t.num_sessions = 1;
  return t;
}

localization_t sample_localization() {
  localization_t m{};
  m.utime = 1700000000000000;
  m.session = 2;
  m.keyframe_id = 41;
  m.localized = true;
  m.localized_since_utime = 1699999999000000;
  m.loops_to_map = 12;
  m.T_map_odom[0] = m.T_map_odom[5] = m.T_map_odom[10] = m.T_map_odom[15] = 1.0;
  m.position[2] = -0.5;
  m.orientation[0] = 1.0;
  return m;
}

loop_event_t sample_event() {
  loop_event_t e{};
  e.stage = "verify";
  e.reason = "accepted";
  e.T_match_query[0] = 1.0;
  return e;
}

/// Every prefix of a valid message is rejected, and every single-byte change either decodes to a message that
/// encodes back to exactly those bytes or is rejected; nothing throws.
template <typename Msg>
void check_truncations_and_flips(const Msg& m) {
  const auto bytes = encode(m);
  for (std::size_t len = 0; len < bytes.size(); ++len) {
    Msg out;
    const DecodeResult r = decode_bounded(bytes.data(), len, DecodeLimits{}, &out);
    INFO("prefix " << len << " of " << bytes.size());
    CHECK_FALSE(r.ok);
    CHECK_FALSE(r.reason.empty());
  }
  std::mt19937 rng(42);
  for (int trial = 0; trial < 2000; ++trial) {
    auto b = bytes;
    b[rng() % b.size()] ^= static_cast<std::uint8_t>(1u + rng() % 255u);
    Msg out;
    const DecodeResult r = decode_bounded(b.data(), b.size(), DecodeLimits{}, &out);
    if (r.ok) CHECK(encode(out) == b);
  }
}

}  // namespace

TEST_CASE("every message type decodes through decode_bounded exactly as LCM encoded it") {
  const point_cloud_t scan = small_scan(5);
  point_cloud_t scan_out;
  auto bytes = encode(scan);
  REQUIRE(decode_bounded(bytes.data(), bytes.size(), DecodeLimits{}, &scan_out).ok);
  CHECK(scan_out.num_points == 5);
  CHECK(scan_out.x[4] == 4.f);
  CHECK(scan_out.frame == "velodyne");
  CHECK(scan_out.num_rings == 16);

  status_t status_out;
  bytes = encode(sample_status());
  REQUIRE(decode_bounded(bytes.data(), bytes.size(), DecodeLimits{}, &status_out).ok);
  CHECK(status_out.channels[1].channel == "ODOMETRY_POSE");
  CHECK(status_out.scans_lost_estimate == 3);
  CHECK(status_out.deskew_skipped == 2);

  trajectory_t traj_out;
  bytes = encode(sample_trajectory(3));
  REQUIRE(decode_bounded(bytes.data(), bytes.size(), DecodeLimits{}, &traj_out).ok);
  CHECK(traj_out.keyframes[2].id == 2);

  loop_event_t event_out;
  bytes = encode(sample_event());
  REQUIRE(decode_bounded(bytes.data(), bytes.size(), DecodeLimits{}, &event_out).ok);
  CHECK(event_out.reason == "accepted");

  pose_t pose{};
  pose.orientation[0] = 1.0;
  pose.position[1] = 2.5;
  pose_t pose_out;
  bytes = encode(pose);
  REQUIRE(decode_bounded(bytes.data(), bytes.size(), DecodeLimits{}, &pose_out).ok);
  CHECK(pose_out.position[1] == 2.5);

  localization_t localization_out;
  bytes = encode(sample_localization());
  REQUIRE(decode_bounded(bytes.data(), bytes.size(), DecodeLimits{}, &localization_out).ok);
  CHECK(localization_out.localized);
  CHECK(localization_out.loops_to_map == 12);
  CHECK(localization_out.position[2] == -0.5);
}

TEST_CASE("the crafted scans that stopped the daemon are refused with the field and the byte offset") {
  const point_cloud_t scan = small_scan(2);
  const std::size_t at = num_points_offset(scan);
  point_cloud_t out;

  SECTION("the right fingerprint followed by random bytes") {
    std::vector<std::uint8_t> b = encode(scan);
    b.resize(4096);
    std::mt19937 rng(7);
    for (std::size_t i = 8; i < b.size(); ++i) b[i] = static_cast<std::uint8_t>(rng());
    const DecodeResult r = decode_bounded(b.data(), b.size(), DecodeLimits{}, &out);
    CHECK_FALSE(r.ok);
    INFO(r.reason);
    CHECK(r.offset >= 24);  // the fingerprint, utime and seq are fine; a length is not
  }
  SECTION("num_points = -1 in a 60-byte message") {
    std::vector<std::uint8_t> b = encode(scan);
    b.resize(60);
    put_int32(&b, at, -1);
    const DecodeResult r = decode_bounded(b.data(), b.size(), DecodeLimits{}, &out);
    CHECK_FALSE(r.ok);
    CHECK(r.reason == "num_points: = -1 is negative");
    CHECK(r.offset == at);
  }
  SECTION("num_points = 2^31 - 1 in a 60-byte message: refused before anything is allocated") {
    std::vector<std::uint8_t> b = encode(scan);
    b.resize(60);
    put_int32(&b, at, 2147483647);
    const DecodeResult r = decode_bounded(b.data(), b.size(), DecodeLimits{}, &out);
    CHECK_FALSE(r.ok);
    CHECK(r.reason.find("exceeds the limit 2000000") != std::string::npos);
    CHECK(out.x.capacity() == 0);
  }
  SECTION("num_points within the limit but more than the bytes present") {
    std::vector<std::uint8_t> b = encode(scan);
    put_int32(&b, at, 1000);
    const DecodeResult r = decode_bounded(b.data(), b.size(), DecodeLimits{}, &out);
    CHECK_FALSE(r.ok);
    CHECK(r.reason.find("needs 16000 bytes") != std::string::npos);
  }
  SECTION("a configured cap on the points per scan") {
    const std::vector<std::uint8_t> b = encode(small_scan(100));
    DecodeLimits limits;
    limits.max_points = 99;
    CHECK_FALSE(decode_bounded(b.data(), b.size(), limits, &out).ok);
    limits.max_points = 100;
    CHECK(decode_bounded(b.data(), b.size(), limits, &out).ok);
  }
  SECTION("string lengths of 0, -5 and 2^31-1, a missing NUL, a NUL inside, trailing bytes, another type") {
    const std::size_t frame_len_at = 24;
    for (std::int32_t len : {0, -5, 2147483647}) {
      std::vector<std::uint8_t> b = encode(scan);
      put_int32(&b, frame_len_at, len);
      const DecodeResult r = decode_bounded(b.data(), b.size(), DecodeLimits{}, &out);
      CHECK_FALSE(r.ok);
      CHECK(r.reason.rfind("frame: ", 0) == 0);
      CHECK(r.offset == frame_len_at);
    }
    std::vector<std::uint8_t> b = encode(scan);
    b[frame_len_at + 4 + 8] = 'x';  // the frame's NUL
    CHECK(decode_bounded(b.data(), b.size(), DecodeLimits{}, &out).reason == "frame: string is not NUL-terminated");
    b = encode(scan);
    b[frame_len_at + 4 + 2] = 0;
    CHECK(decode_bounded(b.data(), b.size(), DecodeLimits{}, &out).reason == "frame: string contains a NUL byte");
    b = encode(scan);
    b.push_back(0);
    CHECK(decode_bounded(b.data(), b.size(), DecodeLimits{}, &out).reason == "end of message: 1 trailing bytes");
    pose_t pose{};
    pose.orientation[0] = 1;
    b = encode(pose);
    CHECK(decode_bounded(b.data(), b.size(), DecodeLimits{}, &out).reason.rfind("fingerprint", 0) == 0);
  }
}

TEST_CASE("every truncation and 2000 random byte flips of every message type are refused or decode exactly") {
  check_truncations_and_flips(small_scan(3));
  check_truncations_and_flips(with_times(small_scan(3)));
  check_truncations_and_flips(sample_status());
  check_truncations_and_flips(sample_trajectory(2));
  check_truncations_and_flips(sample_event());
  check_truncations_and_flips(sample_localization());
  pose_t pose{};
  pose.orientation[0] = 1;
  check_truncations_and_flips(pose);
  imu_t imu{};
  imu.angular_velocity[2] = 0.5;
  check_truncations_and_flips(imu);
}

TEST_CASE("imu_t: a gyro sample decodes exactly, and a non-finite or impossible turn rate is refused with the reason") {
  ImuSample sample;
  sample.utime = 1700000000005000;
  sample.angular_velocity = Eigen::Vector3d(0.01, -0.02, 1.25);
  const imu_t msg = to_message(sample, 7);
  const auto bytes = encode(msg);
  CHECK(bytes.size() == 8 + 8 + 8 + 6 * 8);  // fingerprint, utime, seq, 6 doubles
  imu_t out;
  REQUIRE(decode_bounded(bytes.data(), bytes.size(), DecodeLimits{}, &out).ok);
  ImuSample back;
  std::string error;
  REQUIRE(from_message(out, &back, &error));
  CHECK(back.utime == sample.utime);
  CHECK(back.angular_velocity == sample.angular_velocity);
  CHECK(out.seq == 7);
  // One byte short or one too many: refused before LCM's decoder.
  CHECK_FALSE(decode_bounded(bytes.data(), bytes.size() - 1, DecodeLimits{}, &out).ok);
  auto longer = bytes;
  longer.push_back(0);
  CHECK_FALSE(decode_bounded(longer.data(), longer.size(), DecodeLimits{}, &out).ok);
  imu_t bad = msg;
  bad.angular_velocity[1] = std::nan("");
  CHECK_FALSE(from_message(bad, &back, &error));
  CHECK(error == "imu_t turn rate is not finite");
  bad.angular_velocity[1] = 250.0;
  CHECK_FALSE(from_message(bad, &back, &error));
  CHECK(error.find("250") != std::string::npos);
}

TEST_CASE("status_t and trajectory_t lengths are checked against the bytes present") {
  std::vector<std::uint8_t> b = encode(sample_status());
  put_int32(&b, 24, 100000);  // num_channels (after fingerprint, utime, uptime_s)
  status_t s;
  DecodeResult r = decode_bounded(b.data(), b.size(), DecodeLimits{}, &s);
  CHECK_FALSE(r.ok);
  CHECK(r.reason.find("num_channels: = 100000 exceeds the limit 1024") == 0);
  put_int32(&b, 24, 1000);
  r = decode_bounded(b.data(), b.size(), DecodeLimits{}, &s);
  CHECK(r.reason.rfind("num_channels: = 1000 needs", 0) == 0);

  const trajectory_t t = sample_trajectory(2);
  b = encode(t);
  const std::size_t at = 8 + 24 + 4 + t.method.size() + 1 + 128;
  put_int32(&b, at, -2);
  trajectory_t out;
  CHECK(decode_bounded(b.data(), b.size(), DecodeLimits{}, &out).reason == "num_keyframes: = -2 is negative");
}

TEST_CASE("a damaged event header in a log is skipped and counted, the events after it are read") {
  const fs::path path = fs::temp_directory_path() / ("loopd_damaged_" + std::to_string(getpid()) + ".lcmlog");
  {
    LogWriter w;
    std::string error;
    REQUIRE(w.open(path.string(), &error));
    for (int i = 0; i < 3; ++i) {
      const std::vector<std::uint8_t> payload(100, static_cast<std::uint8_t>(i));
      REQUIRE(w.write("CH" + std::to_string(i), 1000 + i, payload.data(), payload.size()));
    }
  }
  // Event layout: sync 4, event number 8, timestamp 8, channel length 4, data length 4, channel 3, data 100.
  const std::size_t event_bytes = 28 + 3 + 100;
  std::vector<char> file(static_cast<std::size_t>(fs::file_size(path)));
  REQUIRE(file.size() == 3 * event_bytes);
  {
    std::FILE* f = std::fopen(path.string().c_str(), "rb");
    REQUIRE(std::fread(file.data(), 1, file.size(), f) == file.size());
    std::fclose(f);
  }
  SECTION("the second event claims 2^31-1 data bytes") {
    for (int i = 0; i < 4; ++i) file[event_bytes + 24 + static_cast<std::size_t>(i)] = "\x7f\xff\xff\xff"[i];
  }
  SECTION("the second event claims a negative channel length") {
    for (int i = 0; i < 4; ++i) file[event_bytes + 20 + static_cast<std::size_t>(i)] = '\xff';
  }
  {
    std::FILE* f = std::fopen(path.string().c_str(), "wb");
    std::fwrite(file.data(), 1, file.size(), f);
    std::fclose(f);
  }
  LogReader r;
  std::string error;
  REQUIRE(r.open(path.string(), &error));
  LogEvent ev;
  std::vector<std::string> channels;
  while (r.next(&ev)) channels.push_back(ev.channel);
  CHECK(channels == std::vector<std::string>{"CH0", "CH2"});
  CHECK(r.stats().corrupt_headers == 1);
  CHECK(r.stats().first_problem_offset == static_cast<std::int64_t>(event_bytes));
  CHECK(r.problems().find("1 corrupt event headers") != std::string::npos);
  fs::remove(path);
}

TEST_CASE("a log cut inside its last event ends at the last whole event and says so") {
  const fs::path path = fs::temp_directory_path() / ("loopd_cut_" + std::to_string(getpid()) + ".lcmlog");
  {
    LogWriter w;
    std::string error;
    REQUIRE(w.open(path.string(), &error));
    const std::vector<std::uint8_t> payload(50, 1);
    REQUIRE(w.write("A", 1, payload.data(), payload.size()));
    REQUIRE(w.write("B", 2, payload.data(), payload.size()));
  }
  fs::resize_file(path, fs::file_size(path) - 10);
  LogReader r;
  std::string error;
  REQUIRE(r.open(path.string(), &error));
  LogEvent ev;
  int n = 0;
  while (r.next(&ev)) ++n;
  CHECK(n == 1);
  CHECK(r.stats().truncated_tail);
  fs::remove(path);
  CHECK_FALSE(r.open(fs::temp_directory_path().string(), &error));
  CHECK(error.find("not a regular file") != std::string::npos);
}

TEST_CASE("trajectory_t: full and total_keyframes decode, and a version-1 message (before them) decodes as a full snapshot") {
  trajectory_t t = sample_trajectory(3);
  t.revision = 7;
  t.keyframes[1].position[0] = 2.5;
  t.full = false;
  t.total_keyframes = 40;
  t.keyframe_sessions.assign(3, 0);  // what an upgrade gives
  t.sessions.clear();
  t.num_sessions = 0;
  std::vector<std::uint8_t> b = encode(t);
  trajectory_t out;
  REQUIRE(decode_bounded(b.data(), b.size(), DecodeLimits{}, &out).ok);
  CHECK_FALSE(out.full);
  CHECK(out.total_keyframes == 40);
  CHECK(out.keyframes[1].position[0] == 2.5);

  // Version 2: before keyframe_sessions (3 x 4 bytes) and num_sessions (4 bytes, no sessions here) were appended; its
  // own fingerprint (0x32d603706da153a4). It decodes as today's message with every keyframe in session 0.
  std::vector<std::uint8_t> v2(b.begin(), b.end() - 16);
  const std::uint8_t v2_hash[8] = {0x32, 0xd6, 0x03, 0x70, 0x6d, 0xa1, 0x53, 0xa4};
  std::memcpy(v2.data(), v2_hash, 8);
  CHECK_FALSE(decode_bounded(v2.data(), v2.size(), DecodeLimits{}, &out).ok);
  REQUIRE(decode_trajectory_v2(v2.data(), v2.size(), DecodeLimits{}, &out).ok);
  CHECK(encode(out) == b);
  CHECK(decode_trajectory_v2(b.data(), b.size(), DecodeLimits{}, &out).reason.find("fingerprint") == 0);

  // The 9 bytes before those are version 2's appended fields: without them the message is cut short at `full`.
  std::vector<std::uint8_t> cut(b.begin(), b.end() - 16 - 9);
  std::memcpy(cut.data(), b.data(), 8);
  DecodeResult r = decode_bounded(cut.data(), cut.size(), DecodeLimits{}, &out);
  CHECK_FALSE(r.ok);
  CHECK(r.reason.rfind("full: needs 1 bytes", 0) == 0);
  CHECK(r.offset == cut.size());

  // Version 1: the same bytes with that version's fingerprint (0x5039562511ef5e3a, from a loopd output log of then).
  std::vector<std::uint8_t> v1 = cut;
  const std::uint8_t v1_hash[8] = {0x50, 0x39, 0x56, 0x25, 0x11, 0xef, 0x5e, 0x3a};
  std::memcpy(v1.data(), v1_hash, 8);
  CHECK_FALSE(decode_bounded(v1.data(), v1.size(), DecodeLimits{}, &out).ok);  // not today's type
  trajectory_t upgraded;
  REQUIRE(decode_trajectory_v1(v1.data(), v1.size(), DecodeLimits{}, &upgraded).ok);
  CHECK(upgraded.full);
  CHECK(upgraded.total_keyframes == 3);
  CHECK(upgraded.revision == 7);
  CHECK(upgraded.method == "heuristic+graph");
  REQUIRE(upgraded.keyframes.size() == 3);
  CHECK(upgraded.keyframes[1].position[0] == 2.5);
  CHECK(upgraded.keyframe_sessions == std::vector<std::int32_t>(3, 0));
  CHECK(upgraded.num_sessions == 0);

  // Today's bytes are not version 1; a damaged version-1 message is refused with the field and offset.
  CHECK(decode_trajectory_v1(b.data(), b.size(), DecodeLimits{}, &upgraded).reason.find("fingerprint") == 0);
  const std::size_t at = 8 + 24 + 4 + t.method.size() + 1 + 128;
  put_int32(&v1, at, 4);
  r = decode_trajectory_v1(v1.data(), v1.size(), DecodeLimits{}, &upgraded);
  CHECK_FALSE(r.ok);
  CHECK(r.reason.rfind("num_keyframes: = 4 needs", 0) == 0);
  CHECK(r.offset == at);
  std::vector<std::uint8_t> trailing = cut;
  std::memcpy(trailing.data(), v1_hash, 8);
  trailing.push_back(0);
  CHECK(decode_trajectory_v1(trailing.data(), trailing.size(), DecodeLimits{}, &upgraded).reason == "end of message: 1 trailing bytes");
}

TEST_CASE("point_cloud_t: per-point times decode, num_point_times other than 0 or num_points is refused before LCM's decoder") {
  const point_cloud_t scan = with_times(small_scan(3));
  std::vector<std::uint8_t> b = encode(scan);
  point_cloud_t out;
  REQUIRE(decode_bounded(b.data(), b.size(), DecodeLimits{}, &out).ok);
  REQUIRE(out.num_point_times == 3);
  CHECK(out.time_offset == scan.time_offset);

  // num_point_times sits after num_rings: 3 points x 4 floats, 3 rings, num_rings.
  const std::size_t at = num_points_offset(scan) + 4 + 3 * 16 + 4 + 3 * 2 + 2;
  for (std::int32_t n : {2, 4, -1, 2147483647}) {
    std::vector<std::uint8_t> bad = b;
    put_int32(&bad, at, n);
    const DecodeResult r = decode_bounded(bad.data(), bad.size(), DecodeLimits{}, &out);
    CHECK_FALSE(r.ok);
    CHECK(r.reason == "num_point_times: = " + std::to_string(n) + " is neither 0 nor num_points (3)");
    CHECK(r.offset == at);
  }
  std::vector<std::uint8_t> cut(b.begin(), b.end() - 4);  // the times cut short
  DecodeResult r = decode_bounded(cut.data(), cut.size(), DecodeLimits{}, &out);
  CHECK(r.reason == "num_point_times: = 3 needs 12 bytes, 8 left");
  std::vector<std::uint8_t> none = encode(small_scan(3));  // 0: no times
  REQUIRE(decode_bounded(none.data(), none.size(), DecodeLimits{}, &out).ok);
  CHECK(out.num_point_times == 0);
  CHECK(out.time_offset.empty());
}

TEST_CASE("a point_cloud_t of version 1 (before per-point times), built from bytes, decodes with no times") {
  const std::vector<std::uint8_t> v1 = point_cloud_v1_bytes();
  point_cloud_t out;
  CHECK(decode_bounded(v1.data(), v1.size(), DecodeLimits{}, &out).reason.rfind("fingerprint", 0) == 0);  // not today's type
  REQUIRE(decode_point_cloud_v1(v1.data(), v1.size(), DecodeLimits{}, &out).ok);
  point_cloud_t any;
  REQUIRE(decode_any_point_cloud(v1.data(), v1.size(), DecodeLimits{}, &any).ok);
  for (const point_cloud_t* m : {&out, &any}) {
    CHECK(m->utime == 1234567);
    CHECK(m->seq == 42);
    CHECK(m->frame == "velodyne");
    REQUIRE(m->num_points == 2);
    CHECK(m->x[1] == -2.0f);
    CHECK(m->y[1] == 3.25f);
    CHECK(m->z[0] == -1.5f);
    CHECK(m->intensity[1] == 9.0f);
    CHECK(m->ring == std::vector<std::int16_t>{3, 15});
    CHECK(m->num_rings == 16);
    CHECK(m->num_point_times == 0);
    CHECK(m->time_offset.empty());
  }
  // Upgraded exactly as trajectory_t version 1 is: today's fingerprint, the same fields, num_point_times = 0 appended.
  std::vector<std::uint8_t> today = encode(out);
  REQUIRE(today.size() == v1.size() + 4);
  CHECK(std::equal(v1.begin() + 8, v1.end(), today.begin() + 8));
  CHECK(std::vector<std::uint8_t>(today.end() - 4, today.end()) == std::vector<std::uint8_t>(4, 0));

  // Today's bytes decode through decode_any_point_cloud too, and are not version 1.
  const std::vector<std::uint8_t> now = encode(with_times(small_scan(2)));
  REQUIRE(decode_any_point_cloud(now.data(), now.size(), DecodeLimits{}, &any).ok);
  CHECK(any.num_point_times == 2);
  CHECK(decode_point_cloud_v1(now.data(), now.size(), DecodeLimits{}, &out).reason.find("fingerprint") == 0);

  // A damaged version-1 message is refused with the field and offset, by either function.
  std::vector<std::uint8_t> bad = v1;
  const std::size_t at = 8 + 8 + 8 + 4 + 9;  // num_points
  put_int32(&bad, at, 3);
  DecodeResult r = decode_any_point_cloud(bad.data(), bad.size(), DecodeLimits{}, &any);
  CHECK_FALSE(r.ok);
  CHECK(r.reason.rfind("num_points: = 3 needs", 0) == 0);
  CHECK(r.offset == at);
  std::vector<std::uint8_t> trailing = v1;
  trailing.push_back(0);
  CHECK(decode_point_cloud_v1(trailing.data(), trailing.size(), DecodeLimits{}, &out).reason == "end of message: 1 trailing bytes");
  CHECK_FALSE(decode_any_point_cloud(v1.data(), 7, DecodeLimits{}, &any).ok);
  CHECK_FALSE(decode_any_point_cloud(nullptr, 0, DecodeLimits{}, &any).ok);

  // Every reader of drive logs takes it: LogReader::decode for point_cloud_t.
  LogEvent ev;
  ev.data = v1;
  CHECK(LogReader::decode(ev, &any));
  CHECK(any.utime == 1234567);
}

TEST_CASE("decode_scan reads either layout straight into the cloud that from_message makes, and refuses what it refuses") {
  point_cloud_t today = with_times(small_scan(5));
  today.ring = {0, 3, -2, 15, 7};  // a negative ring is clamped to 0, as from_message does
  today.x[2] = std::numeric_limits<float>::quiet_NaN();
  const std::vector<std::uint8_t> b = encode(today);
  PointCloud expected;
  std::string error;
  REQUIRE(from_message(today, &expected, &error));
  DecodedScan scan;
  REQUIRE(decode_scan(b.data(), b.size(), DecodeLimits{}, &scan).ok);
  CHECK(scan.utime == 1000);
  CHECK(scan.seq == 7);
  REQUIRE(scan.cloud.size() == 5);
  CHECK(scan.cloud.points[4] == Eigen::Vector3f(4.0f, 1.5f, -0.5f));
  CHECK(std::isnan(scan.cloud.points[2].x()));
  CHECK(scan.cloud.intensity == expected.intensity);
  CHECK(scan.cloud.ring == std::vector<std::uint16_t>{0, 3, 0, 15, 7});
  CHECK(scan.cloud.num_rings == 16);
  CHECK(scan.cloud.time == today.time_offset);

  // Version 1: no times, rings kept.
  const std::vector<std::uint8_t> v1 = point_cloud_v1_bytes();
  REQUIRE(decode_scan(v1.data(), v1.size(), DecodeLimits{}, &scan).ok);
  CHECK(scan.utime == 1234567);
  CHECK(scan.seq == 42);
  REQUIRE(scan.cloud.size() == 2);
  CHECK(scan.cloud.points[1] == Eigen::Vector3f(-2.0f, 3.25f, 0.0f));
  CHECK(scan.cloud.ring == std::vector<std::uint16_t>{3, 15});
  CHECK_FALSE(scan.cloud.has_time());

  // Refused, with the reason and the offset, and `out` left as it was.
  const auto refused = [&](const std::vector<std::uint8_t>& bytes) {
    DecodedScan kept;
    kept.utime = -5;
    const DecodeResult r = decode_scan(bytes.data(), bytes.size(), DecodeLimits{}, &kept);
    CHECK(kept.utime == -5);
    return r;
  };
  point_cloud_t late = today;
  late.time_offset[3] = 1.5f;
  DecodeResult r = refused(encode(late));
  CHECK(r.reason == "point_cloud_t time_offset 1.500000 s is not finite or beyond 1.000000 s");
  CHECK(r.offset == b.size() - 8);
  point_cloud_t many_rings = today;
  many_rings.num_rings = 600;
  CHECK(refused(encode(many_rings)).reason == "point_cloud_t num_rings = 600 is outside 0..512");
  point_cloud_t few_rings = today;
  few_rings.num_ring_indices = 2;
  few_rings.ring.resize(2);
  CHECK(refused(encode(few_rings)).reason == "point_cloud_t num_ring_indices is neither 0 nor num_points");
  std::vector<std::uint8_t> huge = b;
  put_int32(&huge, num_points_offset(today), 2147483647);
  r = refused(huge);
  CHECK(r.reason == "num_points: = 2147483647 exceeds the limit 2000000");
  CHECK(r.offset == num_points_offset(today));
  CHECK(refused(std::vector<std::uint8_t>(b.begin(), b.end() - 1)).reason.rfind("num_point_times: = 5 needs", 0) == 0);
  CHECK(refused(encode(sample_event())).reason.rfind("fingerprint", 0) == 0);
  CHECK_FALSE(decode_scan(nullptr, 0, DecodeLimits{}, &scan).ok);
}

TEST_CASE("loop_event_t: a version-1 event (before sessions and retrieval) decodes as sessions 0 / 0, retrieval gate") {
  loop_event_t e = sample_event();
  e.query_id = 12;
  e.match_id = 3;
  e.retrieval = "gate";
  e.place_distance = -1.0;
  const std::vector<std::uint8_t> b = encode(e);
  // Version 1 is today's bytes without the appended 4 + 4 + (4 + 5) + 8 bytes, with its own fingerprint.
  std::vector<std::uint8_t> v1(b.begin(), b.end() - 25);
  const std::uint8_t v1_hash[8] = {0x0c, 0xa9, 0x21, 0x30, 0x2b, 0x50, 0xcd, 0x2a};
  std::memcpy(v1.data(), v1_hash, 8);
  loop_event_t out;
  CHECK_FALSE(decode_bounded(v1.data(), v1.size(), DecodeLimits{}, &out).ok);
  REQUIRE(decode_any_loop_event(v1.data(), v1.size(), DecodeLimits{}, &out).ok);
  CHECK(encode(out) == b);
  CHECK(out.query_session == 0);
  CHECK(out.retrieval == "gate");
  CHECK(out.place_distance == -1.0);
  // Today's layout goes straight through; a damaged version-1 event is refused with the field.
  e.query_session = 2;
  e.retrieval = "global";
  const std::vector<std::uint8_t> now = encode(e);
  REQUIRE(decode_any_loop_event(now.data(), now.size(), DecodeLimits{}, &out).ok);
  CHECK(out.query_session == 2);
  std::vector<std::uint8_t> cut(v1.begin(), v1.end() - 1);
  const DecodeResult r = decode_any_loop_event(cut.data(), cut.size(), DecodeLimits{}, &out);
  CHECK_FALSE(r.ok);
  CHECK(r.reason.find("ms_descriptor .. ms_total") == 0);
}
