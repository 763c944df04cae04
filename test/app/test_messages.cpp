#include <catch2/catch.hpp>
#include <lcm/lcm-cpp.hpp>

#include <cmath>

#include <loopd/loop_event_t.hpp>
#include <loopd/status_t.hpp>
#include <loopd/trajectory_t.hpp>

#include "message_convert.hpp"
#include "output_messages.hpp"

using namespace loopd;

namespace {
/// Publishes on memq:// and returns the bytes the subscriber received.
struct Catcher {
  std::vector<std::uint8_t> bytes;
  void on_raw(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    const auto* d = static_cast<const std::uint8_t*>(rbuf->data);
    bytes.assign(d, d + rbuf->data_size);
  }
};
template <typename Msg>
Msg round_trip(const Msg& msg) {
  lcm::LCM lcm("memq://");
  REQUIRE(lcm.good());
  Catcher c;
  lcm.subscribe("T", &Catcher::on_raw, &c);
  REQUIRE(lcm.publish("T", &msg) == 0);
  REQUIRE(lcm.handleTimeout(1000) > 0);
  Msg out;
  REQUIRE(out.decode(c.bytes.data(), 0, static_cast<int>(c.bytes.size())) == static_cast<int>(c.bytes.size()));
  return out;
}
}  // namespace

TEST_CASE("point_cloud_t round-trips through LCM with rings and intensity") {
  PointCloud cloud;
  cloud.points = {{1.f, 2.f, 3.f}, {-4.f, 5.5f, 0.25f}};
  cloud.intensity = {7.f, 9.f};
  cloud.ring = {3, 60};
  cloud.num_rings = 64;
  const point_cloud_t out = round_trip(to_message(cloud, 123456, 7, "velodyne"));
  PointCloud back;
  std::string error;
  REQUIRE(from_message(out, &back, &error));
  CHECK(out.utime == 123456);
  CHECK(out.frame == "velodyne");
  CHECK(back.points[1].isApprox(cloud.points[1]));
  CHECK(back.intensity[1] == 9.f);
  CHECK(back.ring[1] == 60);
  CHECK(back.num_rings == 64);
}

TEST_CASE("point_cloud_t carries per-point times when the cloud has them, bad times are refused") {
  PointCloud cloud;
  cloud.points = {{1.f, 2.f, 3.f}, {-4.f, 5.5f, 0.25f}, {0.f, 1.f, 0.f}};
  const point_cloud_t none = round_trip(to_message(cloud, 1, 1, "lidar"));
  CHECK(none.num_point_times == 0);
  PointCloud back;
  std::string error;
  REQUIRE(from_message(none, &back, &error));
  CHECK_FALSE(back.has_time());

  cloud.time = {-0.099f, -0.05f, 0.0f};
  point_cloud_t msg = round_trip(to_message(cloud, 2, 2, "lidar"));
  REQUIRE(msg.num_point_times == 3);
  REQUIRE(from_message(msg, &back, &error));
  REQUIRE(back.has_time());
  CHECK(back.time == cloud.time);

  msg.time_offset[1] = std::nanf("");
  CHECK_FALSE(from_message(msg, &back, &error));
  CHECK(error.find("time_offset") != std::string::npos);
  msg.time_offset[1] = -1.5f;  // beyond kMaxPointTimeOffset: another clock, not a time within the sweep
  CHECK_FALSE(from_message(msg, &back, &error));
  msg.time_offset[1] = -1.0f;
  CHECK(from_message(msg, &back, &error));
  msg.num_point_times = 2;
  msg.time_offset.resize(2);
  CHECK_FALSE(from_message(msg, &back, &error));
  CHECK(error.find("num_point_times") != std::string::npos);
}

TEST_CASE("pose_t round-trips, and non-finite poses are refused") {
  StampedPose p;
  p.utime = 42;
  p.T_world_sensor = make_isometry(1, 2, 3, 0.5, 0.1, -0.2);
  p.residual = 0.03;
  pose_t msg = round_trip(to_message(p, 3));
  StampedPose back;
  std::string error;
  REQUIRE(from_message(msg, &back, &error));
  CHECK(back.T_world_sensor.isApprox(p.T_world_sensor, 1e-12));
  CHECK(back.residual == Approx(0.03));
  msg.position[1] = std::nan("");
  CHECK_FALSE(from_message(msg, &back, &error));
  CHECK(error.find("position") != std::string::npos);
}

TEST_CASE("loop_event_t, trajectory_t and status_t round-trip") {
  LoopDecision d;
  d.event_id = 5;
  d.query = KeyframeKey{0, 100};
  d.match = KeyframeKey{0, 3};
  d.query_utime = 10'000'000;
  d.match_utime = 300'000;
  d.status = LoopStatus::kAccepted;
  d.stage = "accepted";
  d.lcp_fraction = 0.8;
  d.T_match_query = make_isometry(1, -2, 0.5, 1.0);
  const loop_event_t e = round_trip(to_message(d, 99));
  CHECK(e.status == loop_event_t::STATUS_ACCEPTED);
  CHECK(e.stage == "accepted");
  CHECK(e.lcp_fraction == Approx(0.8));
  CHECK(from_row_major(e.T_match_query).isApprox(d.T_match_query, 1e-12));

  CorrectionOutput c;
  c.revision = 2;
  c.method = "heuristic";
  c.keys = {KeyframeKey{0, 0}, KeyframeKey{0, 1}};
  c.utimes = {10, 20};
  c.T_map_sensor = {Eigen::Isometry3d::Identity(), make_isometry(3, 0, 0, 0.3)};
  const trajectory_t t = round_trip(to_message(c, 77));
  REQUIRE(t.num_keyframes == 2);
  CHECK(t.keyframes[1].position[0] == Approx(3.0));
  CHECK(t.keyframes[1].utime == 20);
  CHECK(t.full);
  CHECK(t.total_keyframes == 2);

  EngineStats s;
  s.keyframes = 12;
  s.device = "cpu";
  s.keyframes_deskewed = 11;
  s.deskew_skipped = 1;
  const status_t st = round_trip(make_status(1, 2.0, s, {{"LIDAR_SCAN", 10, 9, 1, 0}}, 1024));
  REQUIRE(st.num_channels == 1);
  CHECK(st.channels[0].malformed == 1);
  CHECK(st.keyframes == 12);
  CHECK(st.device == "cpu");
  CHECK(st.keyframes_deskewed == 11);
  CHECK(st.deskew_skipped == 1);

  MapStatus map;
  map.path = "/var/lib/loopd/map.db";
  map.bytes = 123456789;
  map.cached_bytes = 4096;
  map.write_failures = 2;
  map.write_retries = 7;
  map.writes_buffered = 3;
  map.events_not_republished = 4;
  map.last_error = "disk full";
  s.session = 5;
  s.sessions_opened = 1;
  s.keyframes_skipped = 40;
  const status_t sm = round_trip(make_status(1, 2.0, s, {}, 1024, map));
  CHECK(sm.map_write_retries == 7);
  CHECK(sm.map_writes_buffered == 3);
  CHECK(sm.events_not_republished == 4);
  CHECK(sm.session == 5);
  CHECK(sm.sessions_opened == 1);
  CHECK(sm.keyframes_skipped == 40);
  CHECK(sm.map_path == "/var/lib/loopd/map.db");
  CHECK(sm.map_bytes == 123456789);
  CHECK(sm.map_cached_bytes == 4096);
  CHECK(sm.map_write_failures == 2);
  CHECK(sm.map_error == "disk full");
}

TEST_CASE("truncated and garbage bytes do not decode") {
  PointCloud cloud;
  cloud.points.assign(100, Eigen::Vector3f(1, 2, 3));
  const point_cloud_t msg = to_message(cloud, 1, 1, "f");
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
  point_cloud_t out;
  CHECK(out.decode(buf.data(), 0, static_cast<int>(buf.size() / 2)) < 0);  // truncated
  std::vector<std::uint8_t> garbage(64, 0xAB);
  CHECK(out.decode(garbage.data(), 0, static_cast<int>(garbage.size())) < 0);
  pose_t p;
  CHECK(p.decode(garbage.data(), 0, 10) < 0);
}
