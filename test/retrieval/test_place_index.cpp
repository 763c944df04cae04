// PlaceIndex: equals a brute-force ranking by place_distance when every entry is a ring-key candidate; the filter,
// k and max_place_distance are honoured.
#include <catch2/catch.hpp>
#include <algorithm>
#include <random>

#include "loopd/retrieval/place_index.hpp"

using namespace loopd;

namespace {

PlaceDescriptor from_bins(std::vector<std::uint8_t> bins) {
  PlaceDescriptor d;
  d.ok = true;
  d.num_rings = 20;
  d.num_sectors = 60;
  d.max_range = 80.f;
  d.height_offset = 2.f;
  d.height_step = 0.1f;
  d.bins = std::move(bins);
  detail::finish_place_descriptor(d);
  return d;
}

/// Random bins, about a third empty.
PlaceDescriptor random_descriptor(std::mt19937& rng) {
  std::uniform_int_distribution<int> v(0, 120), empty(0, 2);
  std::vector<std::uint8_t> bins(1200);
  for (auto& b : bins) b = static_cast<std::uint8_t>(empty(rng) == 0 ? 0 : v(rng));
  return from_bins(bins);
}

/// A perturbed copy of `base`: columns turned by a random shift, +-3 steps of noise on occupied bins.
PlaceDescriptor near(const PlaceDescriptor& base, std::mt19937& rng) {
  std::uniform_int_distribution<int> shift(0, 59), noise(-3, 3);
  const int k = shift(rng);
  std::vector<std::uint8_t> bins(1200);
  for (int s = 0; s < 60; ++s)
    for (int r = 0; r < 20; ++r) {
      const int v = base.bins[static_cast<std::size_t>(s * 20 + r)];
      bins[static_cast<std::size_t>(((s + k) % 60) * 20 + r)] = static_cast<std::uint8_t>(v == 0 ? 0 : std::clamp(v + noise(rng), 1, 255));
    }
  return from_bins(bins);
}

std::vector<PlaceCandidate> brute_force(const std::vector<std::pair<KeyframeKey, PlaceDescriptor>>& entries, const PlaceDescriptor& q, int k,
                                        float max_d, const std::function<bool(const KeyframeKey&)>& accept) {
  std::vector<PlaceCandidate> all;
  for (const auto& [key, d] : entries) {
    if (accept && !accept(key)) continue;
    const PlaceMatch m = place_distance(q, d);
    if (m.distance <= max_d) all.push_back({key, 0.f, m.distance, m.yaw_match_query});
  }
  std::sort(all.begin(), all.end(), [](const PlaceCandidate& a, const PlaceCandidate& b) {
    return a.place_distance < b.place_distance || (a.place_distance == b.place_distance && a.key < b.key);
  });
  if (all.size() > static_cast<std::size_t>(k)) all.resize(static_cast<std::size_t>(k));
  return all;
}

void check_same(const std::vector<PlaceCandidate>& got, const std::vector<PlaceCandidate>& want) {
  REQUIRE(got.size() == want.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    INFO("rank " << i);
    CHECK(got[i].key == want[i].key);
    CHECK(got[i].place_distance == want[i].place_distance);
    CHECK(got[i].yaw_match_query == want[i].yaw_match_query);
  }
}

}  // namespace

TEST_CASE("PlaceIndex::query equals a brute-force ranking when ring_candidates >= size (random and clustered)") {
  const bool clustered = GENERATE(false, true);
  std::mt19937 rng(clustered ? 11 : 12);
  std::vector<PlaceDescriptor> bases;
  for (int i = 0; i < 8; ++i) bases.push_back(random_descriptor(rng));
  std::vector<std::pair<KeyframeKey, PlaceDescriptor>> entries;
  PlaceIndex index;
  for (int i = 0; i < 300; ++i) {
    PlaceDescriptor d = clustered ? near(bases[static_cast<std::size_t>(i % 8)], rng) : random_descriptor(rng);
    const KeyframeKey key{i % 3, i};
    entries.emplace_back(key, d);
    REQUIRE(index.add(key, d));
  }
  REQUIRE(index.size() == 300);
  CHECK(index.bytes() >= 300u * (1200 + 60 * 4 + 20 * 4));
  RetrievalConfig config;
  config.k = 10;
  config.ring_candidates = 300;
  config.max_place_distance = 1.f;
  for (int t = 0; t < 10; ++t) {
    const PlaceDescriptor q = clustered ? near(bases[static_cast<std::size_t>(t % 8)], rng) : random_descriptor(rng);
    PlaceQueryStats stats;
    check_same(index.query(q, config, {}, &stats), brute_force(entries, q, config.k, config.max_place_distance, {}));
    CHECK(stats.accepted == 300);
    CHECK(stats.compared == 300);
    const auto session1 = [](const KeyframeKey& k) { return k.session == 1; };
    check_same(index.query(q, config, session1), brute_force(entries, q, config.k, config.max_place_distance, session1));
  }
}

TEST_CASE("PlaceIndex::query honours the filter, k, ring_candidates and max_place_distance") {
  std::mt19937 rng(5);
  const PlaceDescriptor base = random_descriptor(rng);
  PlaceIndex index;
  for (int i = 0; i < 100; ++i) REQUIRE(index.add({0, i}, i < 20 ? near(base, rng) : random_descriptor(rng)));
  const PlaceDescriptor q = near(base, rng);
  RetrievalConfig config;
  config.max_place_distance = 1.f;
  std::vector<PlaceCandidate> got = index.query(q, config);
  REQUIRE(got.size() == 3);
  for (const auto& c : got) CHECK(c.key.index < 20);  // the perturbed copies are nearest
  CHECK(got[0].place_distance <= got[1].place_distance);
  CHECK(got[1].place_distance <= got[2].place_distance);

  std::size_t calls = 0;
  const auto odd = [&calls](const KeyframeKey& k) { return ++calls, k.index % 2 == 1; };
  PlaceQueryStats stats;
  got = index.query(q, config, odd, &stats);
  CHECK(calls == 100);
  CHECK(stats.accepted == 50);
  for (const auto& c : got) CHECK(c.key.index % 2 == 1);
  CHECK(index.query(q, config, [](const KeyframeKey&) { return false; }).empty());

  config.k = 7;
  CHECK(index.query(q, config).size() == 7);
  config.ring_candidates = 7;
  index.query(q, config, {}, &stats);
  CHECK(stats.compared == 7);

  config.ring_candidates = 100;
  config.k = 100;
  config.max_place_distance = 0.2f;
  got = index.query(q, config);
  REQUIRE(!got.empty());
  CHECK(got.size() <= 20);
  for (const auto& c : got) CHECK(c.place_distance <= 0.2f);
}

TEST_CASE("PlaceIndex rejects unusable descriptors and configs") {
  std::mt19937 rng(9);
  PlaceIndex index;
  CHECK_FALSE(index.add({0, 0}, PlaceDescriptor{}));
  REQUIRE(index.add({0, 1}, random_descriptor(rng)));
  PlaceDescriptor other = random_descriptor(rng);
  other.height_step = 0.2f;
  CHECK_FALSE(index.add({0, 2}, other));
  CHECK(index.size() == 1);
  RetrievalConfig bad;
  bad.k = 0;
  CHECK(bad.validate().has_value());
  CHECK(index.query(random_descriptor(rng), bad).empty());
  bad = RetrievalConfig{};
  bad.ring_candidates = 1;
  CHECK(bad.validate().has_value());
  bad = RetrievalConfig{};
  bad.max_place_distance = 2.f;
  CHECK(bad.validate().has_value());
  CHECK_FALSE(RetrievalConfig{}.validate().has_value());
}

TEST_CASE("PlaceIndex::remove takes an entry out for good: queries equal a brute force over the entries left") {
  std::mt19937 rng(13);
  std::vector<std::pair<KeyframeKey, PlaceDescriptor>> entries;
  PlaceIndex index;
  for (int i = 0; i < 200; ++i) {
    const KeyframeKey key{0, i};
    entries.emplace_back(key, random_descriptor(rng));
    REQUIRE(index.add(key, entries.back().second));
  }
  // Every third entry out (the last one too: no entry moves into its slot), then one that is gone already.
  std::vector<std::pair<KeyframeKey, PlaceDescriptor>> left;
  for (const auto& e : entries) {
    if (e.first.index % 3 == 2 || e.first.index == 199) {
      REQUIRE(index.remove(e.first));
    } else {
      left.push_back(e);
    }
  }
  CHECK_FALSE(index.remove(KeyframeKey{0, 2}));
  CHECK_FALSE(index.remove(KeyframeKey{5, 0}));
  REQUIRE(index.size() == left.size());
  RetrievalConfig config;
  config.k = 20;
  config.ring_candidates = 200;
  config.max_place_distance = 1.f;
  for (int t = 0; t < 10; ++t) {
    const PlaceDescriptor q = t < 5 ? random_descriptor(rng) : left[static_cast<std::size_t>(7 * t)].second;  // some exact revisits
    check_same(index.query(q, config), brute_force(left, q, config.k, config.max_place_distance, {}));
  }
  // compare() knows only the entries left.
  const PlaceDescriptor q = entries[4].second;
  const std::vector<PlaceCandidate> named = index.compare({&q}, {KeyframeKey{0, 4}, KeyframeKey{0, 5}}, 1.f);
  REQUIRE(named.size() == 1);
  CHECK(named[0].key == KeyframeKey{0, 4});
}
