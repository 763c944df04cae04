#pragma once
// Shared by the map store tests of every back end: records with awkward values (poses with all 12 numbers set, NaN
// fields, information matrices), a small two-session map, and exact comparisons.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <map>
#include <optional>
#include <set>
#include <vector>

#include "loopd/store/map_cloud_codec.hpp"
#include "loopd/store/map_store.hpp"
#include "map_test_scene.hpp"

namespace loopd::map_test {

#define REQUIRE_OK(expr)                              \
  do {                                                \
    const StoreStatus st_ = (expr);                   \
    INFO(to_string(st_.code) << ": " << st_.message); \
    REQUIRE(st_.ok());                                \
  } while (0)

inline Eigen::Isometry3d pose(double x, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d(0.1, 0.2, 0.97).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, -0.3 * x, 0.01 * x + 1e-9);
  return T;
}

inline SessionRecord session(SessionId id) {
  SessionRecord s;
  s.id = id;
  s.first_utime = 1700000000000000 + id;
  s.sensor = "hdl64";
  s.source = "replay drive_" + std::to_string(id) + ".lcmlog";
  s.T_map_session = pose(3.5 * id, 0.1 * id);
  s.anchored = id == 0;
  return s;
}

inline MapKeyframe keyframe(SessionId s, std::int64_t i, std::shared_ptr<const KeyframeFeatures> features) {
  MapKeyframe k;
  k.record.key = KeyframeKey{s, i};
  k.record.utime = 1700000000000000 + 100000 * i + s;
  k.record.T_odom_sensor = pose(1.7 * static_cast<double>(i), 0.013 * static_cast<double>(i));
  k.record.residual = 0.031 * static_cast<double>(i + 1);
  k.record.travelled = 2.0 * static_cast<double>(i) + 0.5 * s;
  if (i % 2 == 1) {  // every other keyframe's step measured by the scans
    MeasuredStep step;
    step.T_previous_this = pose(1.7, 0.013 + 0.001 * s);
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) step.information(r, c) = r == c ? 1e4 + i : 1.0 / (r + c + 2.0);
    k.record.step = step;
  }
  k.record.features = std::move(features);
  k.T_map_sensor = pose(1.7 * static_cast<double>(i) + 0.2, 0.013 * static_cast<double>(i) + 0.001);
  return k;
}

inline LoopDecision loop(std::int64_t event, KeyframeKey query, KeyframeKey match, bool accepted) {
  LoopDecision l;
  l.event_id = event;
  l.query = query;
  l.match = match;
  l.query_utime = 1000 + event;
  l.match_utime = 17 + event;
  l.status = accepted ? LoopStatus::kAccepted : LoopStatus::kRejected;
  l.stage = accepted ? "accepted" : "gicp";
  l.reason = accepted ? "" : "fitness 0.31 < 0.5";
  l.gate_distance = 3.25;
  l.gate_radius = 12.5;
  l.descriptor_distance = 0.1234567;
  l.lcp_fraction = 0.77;
  l.icp_residual = 0.0456;
  l.icp_fitness = 0.91;
  l.hungarian_consistency = 0.66;
  l.degeneracy = std::nan("");
  l.T_match_query = pose(0.42, -0.05);
  if (accepted) {
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) l.information(r, c) = r == c ? 1000.0 + r : 1.0 / (r + c + 3.0);
  }
  return l;
}

inline void require_same_loop(const LoopDecision& a, const LoopDecision& b) {
  CHECK(a.event_id == b.event_id);
  CHECK(a.query == b.query);
  CHECK(a.match == b.match);
  CHECK(a.query_utime == b.query_utime);
  CHECK(a.match_utime == b.match_utime);
  CHECK(a.status == b.status);
  CHECK(a.stage == b.stage);
  CHECK(a.reason == b.reason);
  for (auto [x, y] : {std::pair{a.gate_distance, b.gate_distance},
                      {a.gate_radius, b.gate_radius},
                      {a.descriptor_distance, b.descriptor_distance},
                      {a.lcp_fraction, b.lcp_fraction},
                      {a.icp_residual, b.icp_residual},
                      {a.icp_fitness, b.icp_fitness},
                      {a.hungarian_consistency, b.hungarian_consistency}}) {
    CHECK(same_bits(x, y));
  }
  CHECK(std::isnan(b.degeneracy) == std::isnan(a.degeneracy));
  CHECK(same_pose(a.T_match_query, b.T_match_query));
  CHECK(std::memcmp(a.information.data(), b.information.data(), 36 * sizeof(double)) == 0);
}

inline std::vector<MapKeyframe> load(MapStore& store, std::optional<SessionId> session, KeyframeLoad depth) {
  std::vector<MapKeyframe> out;
  REQUIRE_OK(store.for_each_keyframe(session, depth, [&](MapKeyframe&& k) { out.push_back(std::move(k)); }));
  return out;
}

inline std::vector<LoopDecision> loops(MapStore& store, bool accepted_only) {
  std::vector<LoopDecision> out;
  REQUIRE_OK(store.for_each_loop(accepted_only, [&](LoopDecision&& l) { out.push_back(std::move(l)); }));
  return out;
}

/// @brief Sessions 0 and 1 with three keyframes each (index 1 of session 1 has no features), features of real scans.
inline void fill(MapStore& store, std::map<std::pair<SessionId, std::int64_t>, MapKeyframe>* written = nullptr) {
  REQUIRE_OK(store.put_session(session(0)));
  REQUIRE_OK(store.put_session(session(1)));
  for (SessionId s : {0, 1}) {
    for (std::int64_t i = 0; i < 3; ++i) {
      const bool shed = s == 1 && i == 1;
      MapKeyframe k = keyframe(s, i, shed ? nullptr : scan_features(static_cast<int>(3 * s + i)));
      REQUIRE_OK(store.put_keyframe(k));
      if (written) (*written)[{s, i}] = k;
    }
  }
}

/// @brief The loop ledger on any back end, on a map fill() made: entries numbered from 1 in order, each loop's last
/// entry decides, a change that changes nothing (or names a rejected or unknown loop) refused with kInvalid and not
/// entered; stats() counts the loops revoked now; the correction keeps the entry it honours.
inline void check_loop_ledger(MapStore& store) {
  using Code = StoreStatus::Code;
  REQUIRE_OK(store.put_loop(loop(1, {0, 2}, {0, 0}, true)));
  REQUIRE_OK(store.put_loop(loop(2, {1, 2}, {0, 1}, true)));
  REQUIRE_OK(store.put_loop(loop(3, {1, 2}, {1, 0}, false)));
  const auto entry = [](std::int64_t event, bool revoked, const std::string& reason) {
    LoopLedgerEntry e;
    e.event_id = event;
    e.revoked = revoked;
    e.who = "operator ünïcode";
    e.reason = reason;
    e.utime = 1765000000000000 + event;
    return e;
  };
  REQUIRE(store.loop_ledger().value.empty());
  StoreResult<std::int64_t> put = store.put_ledger_entry(entry(2, true, "doubled wall on the east side; 'quoted'"));
  REQUIRE_OK(put.status);
  CHECK(put.value == 1);
  for (const LoopLedgerEntry& refused :
       {entry(2, true, "twice"), entry(1, false, "not revoked"), entry(3, true, "rejected"), entry(99, true, "unknown")}) {
    const StoreResult<std::int64_t> r = store.put_ledger_entry(refused);
    INFO(refused.reason << ": " << r.status.message);
    CHECK(r.status.code == Code::kInvalid);
    CHECK(r.status.message.find("loop event " + std::to_string(refused.event_id)) != std::string::npos);
  }
  CHECK(store.stats().value.loops_revoked == 1);
  put = store.put_ledger_entry(entry(1, true, ""));
  REQUIRE_OK(put.status);
  CHECK(put.value == 2);
  put = store.put_ledger_entry(entry(2, false, "it was the map, not the loop"));
  REQUIRE_OK(put.status);
  CHECK(put.value == 3);
  const StoreResult<std::vector<LoopLedgerEntry>> all = store.loop_ledger();
  REQUIRE_OK(all.status);
  REQUIRE(all.value.size() == 3);
  CHECK(all.value[0].seq == 1);
  CHECK(all.value[0].event_id == 2);
  CHECK(all.value[0].revoked);
  CHECK(all.value[0].who == "operator ünïcode");
  CHECK(all.value[0].reason == "doubled wall on the east side; 'quoted'");
  CHECK(all.value[0].utime == 1765000000000002);
  CHECK_FALSE(all.value[2].revoked);
  CHECK(revoked_loops(all.value) == std::set<std::int64_t>{1});
  CHECK(revoked_loops(all.value, 1) == std::set<std::int64_t>{2});
  CHECK(newest_seq(all.value) == 3);
  const StoreResult<std::vector<LoopLedgerEntry>> news = store.loop_ledger(2);
  REQUIRE_OK(news.status);
  REQUIRE(news.value.size() == 1);
  CHECK(news.value[0].seq == 3);
  CHECK(store.stats().value.loops_revoked == 1);
  CorrectionRecord c;
  c.revision = 4;
  c.loop_event_id = 2;
  c.method = "ledger";
  c.ledger_seq = 3;
  REQUIRE_OK(store.put_correction(c));
  const auto read = store.correction();
  REQUIRE_OK(read.status);
  REQUIRE(read.value);
  CHECK(read.value->ledger_seq == 3);
}

/// @brief Retiring keyframes on any back end, on a map fill() made: the rows keep key, time, poses, travel and step
/// and lose their features and map cloud; a key the map does not hold refuses the whole call; retiring twice is no
/// change; stats() and check() agree.
inline void check_retire_keyframes(MapStore& store) {
  using Code = StoreStatus::Code;
  MapKeyframe clouded = keyframe(0, 3, scan_features(9));
  PointCloud cloud;
  for (int i = 0; i < 300; ++i) cloud.points.emplace_back(0.02f * static_cast<float>(i), std::cos(0.1f * static_cast<float>(i)), 1.5f);
  clouded.map_cloud = std::make_shared<const std::vector<std::uint8_t>>(encode_map_cloud(cloud, 0.01));
  REQUIRE_OK(store.put_keyframe(clouded));
  REQUIRE_OK(store.put_loop(loop(1, {0, 3}, {0, 0}, true)));  // a retired keyframe stays a loop end
  REQUIRE(store.stats().value.map_clouds == 1);

  const StoreStatus missing = store.retire_keyframes({{0, 2}, {7, 0}});
  INFO(missing.message);
  CHECK(missing.code == Code::kNotFound);
  CHECK(missing.message.find("7/0") != std::string::npos);
  CHECK(store.stats().value.keyframes_retired == 0);  // nothing of the refused call

  REQUIRE_OK(store.retire_keyframes({{0, 3}, {0, 2}}));
  REQUIRE_OK(store.retire_keyframes({{0, 3}}));  // again: already retired, nothing changes
  const StoreResult<MapStats> stats = store.stats();
  REQUIRE_OK(stats.status);
  CHECK(stats.value.keyframes == 7);
  CHECK(stats.value.keyframes_retired == 2);
  CHECK(stats.value.map_clouds == 0);
  CHECK(stats.value.loops_accepted == 1);

  std::map<std::pair<SessionId, std::int64_t>, MapKeyframe> read;
  REQUIRE_OK(store.for_each_keyframe(std::nullopt, KeyframeLoad::kFull, [&](MapKeyframe&& k) {
    read[{k.record.key.session, k.record.key.index}] = std::move(k);
  }));
  REQUIRE(read.size() == 7);
  for (const auto& [key, k] : read) {
    INFO("keyframe " << key.first << "/" << key.second);
    const bool retired = key.first == 0 && key.second >= 2;
    CHECK(k.retired == retired);
    if (retired) CHECK(k.record.features == nullptr);
    if (!retired && !(key.first == 1 && key.second == 1)) CHECK(k.record.features != nullptr);  // 1/1 was shed
  }
  // The retired rows keep their place in the chain exactly.
  const MapKeyframe written = keyframe(0, 3, nullptr);
  const MapKeyframe& kept = read[{0, 3}];
  CHECK(kept.record.utime == written.record.utime);
  CHECK(kept.record.T_odom_sensor.matrix() == written.record.T_odom_sensor.matrix());
  CHECK(kept.T_map_sensor.matrix() == written.T_map_sensor.matrix());
  CHECK(kept.record.travelled == written.record.travelled);
  REQUIRE(kept.record.step);
  CHECK(kept.record.step->T_previous_this.matrix() == written.record.step->T_previous_this.matrix());
  CHECK(store.get_prepared({0, 3}).status.code == Code::kNotFound);
  CHECK(store.get_map_cloud({0, 3}).status.code == Code::kNotFound);
  CHECK(store.get_prepared({0, 1}).ok());
  REQUIRE_OK(store.check());
}

}  // namespace loopd::map_test
