// The live page's feed (src/loopd/web/view_feed): what a page is sent, in messages of a bounded size, from where it is.
#include <catch2/catch.hpp>

#include <nlohmann/json.hpp>

#include "loopd/web/view_feed.hpp"

using namespace loopd;
using Json = nlohmann::json;

namespace {

Eigen::Isometry3d pose(double x, double y, double yaw_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0.5);
  T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

LoopDecision decision(std::int64_t id, std::int64_t q, std::int64_t m, bool accepted, const std::string& stage) {
  LoopDecision d;
  d.event_id = id;
  d.query = {0, q};
  d.match = {0, m};
  d.status = accepted ? LoopStatus::kAccepted : LoopStatus::kRejected;
  d.stage = accepted ? "accepted" : stage;
  d.reason = accepted ? "" : "too few \"matches\"";  // quotes: the JSON must escape them
  d.descriptor_distance = 0.125;
  d.ms_total = 10.0 + static_cast<double>(id);
  d.T_match_query = pose(1.0, -2.0, 5.0);
  return d;
}

/// Every message a page at `cursor` is sent until it has had everything, each at most `budget` bytes (+ one item).
std::vector<Json> drain(const ViewFeed& feed, ViewCursor* cursor, std::size_t budget, std::size_t* largest = nullptr) {
  std::vector<Json> out;
  for (int i = 0; i < 100000; ++i) {
    const std::string m = feed.next_message(cursor, budget);
    if (m.empty()) break;
    if (largest) *largest = std::max(*largest, m.size());
    out.push_back(Json::parse(m));
  }
  return out;
}

}  // namespace

TEST_CASE("base64 encodes RFC 4648's test vectors") {
  const auto b64 = [](const std::string& s) { return base64_encode(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()); };
  CHECK(b64("") == "");
  CHECK(b64("f") == "Zg==");
  CHECK(b64("fo") == "Zm8=");
  CHECK(b64("foo") == "Zm9v");
  CHECK(b64("foob") == "Zm9vYg==");
  CHECK(b64("fooba") == "Zm9vYmE=");
  CHECK(b64("foobar") == "Zm9vYmFy");
}

TEST_CASE("view feed: a new page gets everything once, in order - then only what is new, and corrected poses only where they moved") {
  ViewFeed feed;
  feed.set_source("replay drive.lcmlog");
  for (int i = 0; i < 5; ++i) feed.add_keyframe({0, i}, 1000000 * (i + 1), pose(10.0 * i, 0, 0), pose(10.0 * i, 0, 0), nullptr);
  feed.add_decision(decision(1, 4, 0, true, ""));
  feed.add_decision(decision(2, 4, 1, false, "fourpcs"));
  feed.set_health({{"keyframes", 5}, {"loops_accepted", 1}}, {{"watchdog", "ok"}});

  ViewCursor page;
  std::vector<Json> first = drain(feed, &page, 1 << 20);
  REQUIRE(first.size() == 1);
  const Json& hello = first[0];
  CHECK(hello["type"] == "hello");
  CHECK(hello["source"] == "replay drive.lcmlog");
  CHECK(hello["more"] == false);
  REQUIRE(hello["keyframes"].size() == 5);
  CHECK(hello["keyframes"][3][0] == 0);
  CHECK(hello["keyframes"][3][1] == 3);
  CHECK(hello["keyframes"][3][2].get<double>() == Approx(4.0));      // [s]
  CHECK(hello["keyframes"][3][3][0].get<double>() == Approx(30.0));  // odometry x
  REQUIRE(hello["poses"].size() == 5);                               // each keyframe's pose in the map, once
  REQUIRE(hello["decisions"].size() == 2);
  CHECK(hello["decisions"][0]["id"] == 1);
  CHECK(hello["decisions"][0]["a"] == true);
  CHECK(hello["decisions"][0]["T_match_query"][0].get<double>() == Approx(1.0));
  CHECK(hello["decisions"][0]["T_match_query"][3].get<double>() == Approx(5.0 * M_PI / 180.0).margin(1e-4));
  CHECK(hello["decisions"][1]["stage"] == "fourpcs");
  CHECK(hello["decisions"][1]["reason"] == "too few \"matches\"");
  CHECK(hello["decisions"][1]["scores"]["descriptor_distance"].get<double>() == Approx(0.125));
  CHECK(hello["decisions"][1]["scores"]["lcp_fraction"].is_null());  // not computed (-1)
  CHECK(hello["health"]["keyframes"] == 5);
  CHECK(hello["health"]["watchdog"] == "ok");
  CHECK(hello["funnel"]["accepted"] == 1);
  CHECK(hello["funnel"]["fourpcs"] == 1);
  CHECK(hello["counts"]["decisions"] == 2);
  CHECK(feed.next_message(&page, 1 << 20).empty());  // nothing new

  // A correction that moves keyframes 3 and 4 by 1 m and the others by 5 mm: only 3 and 4 are sent again.
  std::vector<KeyframeKey> keys;
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 5; ++i) {
    keys.push_back({0, i});
    poses.push_back(pose(10.0 * i + (i >= 3 ? 1.0 : 0.005), 0, 0));
  }
  feed.set_correction(7, keys, poses);
  feed.add_keyframe({0, 5}, 6000000, pose(50, 0, 0), pose(51, 0, 0), nullptr);
  std::vector<Json> next = drain(feed, &page, 1 << 20);
  REQUIRE(next.size() == 1);
  CHECK(next[0]["type"] == "update");
  CHECK(next[0]["revision"] == 7);
  REQUIRE(next[0]["keyframes"].size() == 1);
  CHECK(next[0]["keyframes"][0][1] == 5);
  REQUIRE(next[0]["poses"].size() == 3);
  CHECK(next[0]["poses"][0][1] == 3);
  CHECK(next[0]["poses"][0][2].get<double>() == Approx(31.0));
  CHECK(next[0]["poses"][1][1] == 4);
  CHECK(next[0]["poses"][2][1] == 5);
  CHECK_FALSE(next[0].contains("decisions"));
  CHECK_FALSE(next[0].contains("health"));

  // A page that connects now gets the newest state in its first message.
  ViewCursor late;
  const std::vector<Json> late_first = drain(feed, &late, 1 << 20);
  REQUIRE(late_first.size() == 1);
  CHECK(late_first[0]["keyframes"].size() == 6);
  CHECK(late_first[0]["poses"].size() == 6);
  CHECK(late_first[0]["poses"][3][2].get<double>() == Approx(31.0));
}

TEST_CASE("view feed: a budget splits the state into messages of about that size that add up to the whole") {
  ViewFeed feed;
  for (int i = 0; i < 400; ++i) feed.add_keyframe({1, i}, 1000000 + i, pose(i, 2.0 * i, i), pose(i, 2.0 * i, i), nullptr);
  for (int i = 0; i < 300; ++i) feed.add_decision(decision(i + 1, i + 50, i, i % 3 == 0, i % 2 ? "descriptor" : "gicp"));
  feed.set_health({{"keyframes", 400}}, {});

  ViewCursor whole;
  const std::vector<Json> one = drain(feed, &whole, 1 << 24);
  REQUIRE(one.size() == 1);

  ViewCursor page;
  std::size_t largest = 0;
  const std::vector<Json> parts = drain(feed, &page, 4096, &largest);
  CHECK(parts.size() > 10);
  CHECK(largest < 4096 + 1024);  // the budget, the message's head and at most one item more
  std::size_t keyframes = 0, poses = 0, decisions = 0, health = 0;
  std::int64_t last_id = 0;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    CHECK(parts[i]["more"] == (i + 1 < parts.size()));
    keyframes += parts[i].value("keyframes", Json::array()).size();
    poses += parts[i].value("poses", Json::array()).size();
    for (const Json& d : parts[i].value("decisions", Json::array())) {
      CHECK(d["id"].get<std::int64_t>() == last_id + 1);  // in the order decided, none twice, none left out
      last_id = d["id"].get<std::int64_t>();
      ++decisions;
    }
    health += parts[i].contains("health");
  }
  CHECK(keyframes == 400);
  CHECK(poses == 400);
  CHECK(decisions == 300);
  CHECK(health == 1);
  CHECK(parts.front()["type"] == "hello");
  CHECK(feed.counts().stages.at("accepted") == 100);
}

TEST_CASE("view feed: rejected decisions are kept to a bound, accepted ones all - the funnel counts every decision") {
  ViewFeedConfig config;
  config.max_rejected = 10;
  ViewFeed feed(config);
  for (int i = 0; i < 100; ++i) feed.add_decision(decision(i + 1, i + 1, 0, i % 10 == 0, "descriptor"));
  ViewCursor page;
  const std::vector<Json> all = drain(feed, &page, 1 << 20);
  REQUIRE(all.size() == 1);
  std::size_t accepted = 0, rejected = 0;
  for (const Json& d : all[0]["decisions"]) (d["a"].get<bool>() ? accepted : rejected)++;
  CHECK(accepted == 10);
  CHECK(rejected == 10);
  CHECK(all[0]["decisions"].back()["id"] == 100);  // the newest are kept
  CHECK(all[0]["funnel"]["descriptor"] == 90);
  CHECK(all[0]["funnel"]["accepted"] == 10);
  CHECK(all[0]["counts"]["decisions"] == 100);
  CHECK(all[0]["verify_ms"]["p50"].get<double>() == Approx(60.0).margin(6.0));
}

TEST_CASE("view feed: keyframe clouds are decimated, levelled by the sensor's roll and pitch, and only the newest kept") {
  ViewFeedConfig config;
  config.clouds = 2;
  config.cloud_points = 100;
  ViewFeed feed(config);
  std::vector<Eigen::Vector3f> cloud{{1000.0f, 0.0f, 0.0f}};  // beyond the +-327 m a page is sent: left out
  for (int i = 0; i < 1000; ++i) cloud.emplace_back(1.0f + 0.01f * static_cast<float>(i), 0.0f, 0.0f);
  Eigen::Isometry3d tilted = pose(0, 0, 30);
  tilted.linear() = tilted.linear() * Eigen::AngleAxisd(-10.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();  // pitched 10 deg up
  for (int i = 0; i < 3; ++i) feed.add_keyframe({0, i}, i, tilted, tilted, &cloud);
  ViewCursor page;
  const std::vector<Json> all = drain(feed, &page, 1 << 20);
  REQUIRE(all.size() == 1);
  REQUIRE(all[0]["clouds"].size() == 2);
  CHECK(all[0]["clouds"][0]["k"][1] == 1);
  const std::string b64 = all[0]["clouds"][0]["p"];
  // 1,001 points, every 11th (at most 100): 91, less the one out of range; 3 int16 each.
  CHECK(b64.size() == (90 * 6 + 2) / 3 * 4);
  // The first point sent (the 12th), 1.1 m ahead of a sensor pitched 10 deg up, lies 1.083 m ahead and 0.191 m up in
  // the levelled frame.
  static const std::string kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::vector<std::uint8_t> bytes;
  for (std::size_t i = 0; i + 3 < b64.size() && bytes.size() < 6; i += 4) {
    std::uint32_t n = 0;
    for (int j = 0; j < 4; ++j) n = n << 6 | static_cast<std::uint32_t>(kAlphabet.find(b64[i + j]));
    bytes.insert(bytes.end(), {static_cast<std::uint8_t>(n >> 16), static_cast<std::uint8_t>(n >> 8), static_cast<std::uint8_t>(n)});
  }
  const auto cm = [&](int axis) { return static_cast<std::int16_t>(bytes[2 * axis] | bytes[2 * axis + 1] << 8); };
  CHECK(cm(0) == 108);
  CHECK(cm(1) == 0);
  CHECK(cm(2) == 19);
}
