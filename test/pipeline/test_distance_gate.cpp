// Distance gate: radius 10% of the distance since the last loop, clamped (Vlaminck 2019, Sec. 4); index and travel
// gaps (Ren 2019, Sec. 3.4.1); the spatial hash must return exactly what a linear scan would.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "loopd/pipeline/distance_gate.hpp"

using namespace loopd;

TEST_CASE("gate radius is 10% of the distance since the last loop, clamped to min and max") {
  const DistanceGateConfig cfg;  // 0.1, 8 m, 40 m
  const DistanceGate g(cfg);
  CHECK(g.radius(0.0) == Approx(8.0));
  CHECK(g.radius(50.0) == Approx(8.0));
  CHECK(g.radius(200.0) == Approx(20.0));
  CHECK(g.radius(399.0) == Approx(39.9));
  CHECK(g.radius(5000.0) == Approx(40.0));
}

TEST_CASE("gate candidates equal a brute-force search, nearest first") {
  DistanceGateConfig cfg;
  DistanceGate g(cfg);
  std::mt19937 rng(7);
  std::normal_distribution<double> step(0.0, 2.0);
  std::vector<GateEntry> all;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  double travelled = 0.0;
  for (int i = 0; i < 3000; ++i) {
    // A random walk folded into a 150 m square: revisits everywhere, positions on both sides of cell borders.
    const Eigen::Vector3d d(step(rng), step(rng), 0.05 * step(rng));
    p += d;
    for (int k = 0; k < 2; ++k) p[k] = std::fmod(std::abs(p[k]), 150.0) - 75.0;
    travelled += d.norm();
    all.push_back({KeyframeKey{0, i}, p, travelled});
  }
  for (const auto& e : all) g.add(e);
  REQUIRE(g.size() == all.size());
  std::uniform_int_distribution<int> pick(0, static_cast<int>(all.size()) - 1);
  std::uniform_real_distribution<double> rad(cfg.min_radius, cfg.max_radius);
  int nonempty = 0;
  for (int t = 0; t < 200; ++t) {
    GateEntry q = all[static_cast<std::size_t>(pick(rng))];
    q.key.index += 1;  // the query is the next keyframe at that place
    const double r = rad(rng);
    std::vector<GateCandidate> expected;
    for (const auto& e : all) {
      if (q.key.index - e.key.index < cfg.min_index_gap || q.travelled - e.travelled < cfg.min_travel_gap) continue;
      const double d = (e.position - q.position).norm();
      if (d <= r) expected.push_back({e.key, d});
    }
    std::sort(expected.begin(), expected.end(), [](const GateCandidate& a, const GateCandidate& b) { return a.distance < b.distance; });
    const std::vector<GateCandidate> got = g.candidates(q, r);
    REQUIRE(got.size() == expected.size());
    for (std::size_t i = 0; i < got.size(); ++i) {
      CHECK(got[i].distance == Approx(expected[i].distance));
      if (i > 0) CHECK(got[i].distance >= got[i - 1].distance);
      CHECK(q.key.index - got[i].key.index >= cfg.min_index_gap);
    }
    nonempty += got.empty() ? 0 : 1;
  }
  CHECK(nonempty > 100);  // the comparison was not vacuous
}

TEST_CASE("recent keyframes are no candidates: index gap and travelled-distance gap") {
  DistanceGateConfig cfg;  // 30 keyframes, 60 m
  DistanceGate g(cfg);
  // A car waiting at a light: 50 keyframes (time rule) at the same place, 10 m travelled in all.
  for (int i = 0; i < 50; ++i) g.add({KeyframeKey{0, i}, Eigen::Vector3d(0.2 * i, 0, 0), 0.2 * i});
  const GateEntry waiting{KeyframeKey{0, 50}, Eigen::Vector3d(10, 0, 0), 10.0};
  CHECK(g.candidates(waiting, 40.0).empty());  // index gap met for 0..20, travel gap for none
  // The same place after a 200 m block: index and travel gaps met.
  g.add({KeyframeKey{0, 50}, Eigen::Vector3d(100, 100, 0), 110.0});
  const GateEntry back{KeyframeKey{0, 51}, Eigen::Vector3d(3, 0.5, 0), 210.0};
  const std::vector<GateCandidate> c = g.candidates(back, 8.0);
  REQUIRE(!c.empty());
  CHECK(c.front().key.index == 15);  // x = 3.0 m exactly
  for (const auto& k : c) CHECK(k.distance <= 8.0);
  // Only 29 keyframes later but far enough travelled: still refused by the index gap.
  const GateEntry soon{KeyframeKey{0, 44 + 29}, Eigen::Vector3d(8.8, 0, 0), 400.0};
  for (const auto& k : g.candidates(soon, 40.0)) CHECK(soon.key.index - k.key.index >= 30);
}

TEST_CASE("after a correction the gate searches the corrected positions") {
  DistanceGate g(DistanceGateConfig{});
  g.add({KeyframeKey{0, 0}, Eigen::Vector3d(0, 0, 0), 0.0});
  g.add({KeyframeKey{0, 1}, Eigen::Vector3d(50, 0, 0), 50.0});
  const GateEntry q{KeyframeKey{0, 100}, Eigen::Vector3d(0, 30, 0), 500.0};
  CHECK(g.candidates(q, 10.0).empty());
  g.update_positions(
      [](const KeyframeKey& k) { return k.index == 0 ? Eigen::Vector3d(0, 25, 0) : Eigen::Vector3d(50, 0, 0); });  // keyframe 0 was really 5 m away
  const auto c = g.candidates(q, 10.0);
  REQUIRE(c.size() == 1);
  CHECK(c[0].key.index == 0);
  CHECK(c[0].distance == Approx(5.0));
}

TEST_CASE("updating the moved entries only gives the same candidates, in the same order, as updating every entry") {
  // Keyframes on a 200 m square; 30 corrections, each moving the entries from a random index on by a random shift
  // (some cross into other cells, some stay); after each, many queries must get the same candidates from both gates.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coord(-100.0, 100.0), shift(-25.0, 25.0);
  DistanceGateConfig config;
  DistanceGate all(config), moved(config);
  std::vector<Eigen::Vector3d> positions;
  for (int i = 0; i < 600; ++i) {
    const GateEntry e{KeyframeKey{0, i}, Eigen::Vector3d(coord(rng), coord(rng), 0.0), 10.0 * i};
    all.add(e);
    moved.add(e);
    positions.push_back(e.position);
  }
  int crossed = 0;
  for (int round = 0; round < 30; ++round) {
    const auto first = static_cast<std::size_t>(std::uniform_int_distribution<int>(0, 599)(rng));
    const Eigen::Vector3d d(shift(rng), shift(rng), 0.0);
    for (std::size_t i = first; i < positions.size(); ++i) {
      const Eigen::Vector3d before = positions[i];
      positions[i] += d * (static_cast<double>(i - first + 1) / static_cast<double>(positions.size() - first));
      if (std::floor(before.x() / config.max_radius) != std::floor(positions[i].x() / config.max_radius)) ++crossed;
    }
    all.update_positions([&](const KeyframeKey& k) { return positions[static_cast<std::size_t>(k.index)]; });
    moved.update_positions_from(first, [&](std::size_t i) { return positions[i]; });
    for (int q = 0; q < 40; ++q) {
      const GateEntry query{KeyframeKey{0, 5000}, Eigen::Vector3d(coord(rng), coord(rng), 0.0), 1e5};
      const auto a = all.candidates(query, 30.0), b = moved.candidates(query, 30.0);
      REQUIRE(a.size() == b.size());
      for (std::size_t k = 0; k < a.size(); ++k) {
        CHECK(a[k].key == b[k].key);
        CHECK(a[k].distance == b[k].distance);
      }
    }
  }
  CHECK(crossed > 100);  // the cells did change: the test exercises the moves between cells
}

TEST_CASE("gate config refuses bad values") {
  DistanceGateConfig c;
  CHECK_FALSE(c.validate());
  c.max_radius = 4.0;  // below min_radius
  CHECK(c.validate());
  c = DistanceGateConfig{};
  c.travel_fraction = 0.0;
  CHECK(c.validate());
  c = DistanceGateConfig{};
  c.min_index_gap = 0;
  CHECK(c.validate());
}

TEST_CASE("a retired entry is never a candidate again, and within() lists a place entries with no gap") {
  DistanceGateConfig cfg;
  DistanceGate g(cfg);
  for (int i = 0; i < 200; ++i) g.add({KeyframeKey{0, i}, Eigen::Vector3d(std::fmod(2.0 * i, 100.0), 0.3 * (i / 50), 0), 2.0 * i});
  // Laps of 50 keyframes along x: keyframes 10, 60, 110, 160 lie at x = 20 m.
  const std::vector<GateCandidate> place = g.within(Eigen::Vector3d(20.0, 0.0, 0.0), 1.0);
  REQUIRE(place.size() == 4);
  CHECK(place[0].key == KeyframeKey{0, 10});  // nearest first (no lateral offset)
  REQUIRE(g.retire(60));
  CHECK_FALSE(g.retire(60));   // once
  CHECK_FALSE(g.retire(500));  // no such entry
  CHECK(g.within(Eigen::Vector3d(20.0, 0.0, 0.0), 1.0).size() == 3);
  const GateEntry query{KeyframeKey{0, 200}, Eigen::Vector3d(20.0, 1.2, 0.0), 400.0};
  for (const GateCandidate& c : g.candidates(query, 8.0)) CHECK(c.key != KeyframeKey{0, 60});
  // Positions still update (entry order kept), and a retired entry does not come back with them.
  g.update_positions([](const KeyframeKey& k) { return Eigen::Vector3d(std::fmod(2.0 * k.index, 100.0) + 0.1, 0.0, 0.0); });
  CHECK(g.within(Eigen::Vector3d(20.1, 0.0, 0.0), 0.5).size() == 3);
  g.update_positions_from(0, [](std::size_t i) { return Eigen::Vector3d(std::fmod(2.0 * static_cast<double>(i), 100.0) + 45.0, 0.0, 0.0); });
  CHECK(g.within(Eigen::Vector3d(65.0, 0.0, 0.0), 0.5).size() == 3);
}
