// KeyframeKey: equality, order, hashing and the keyframe gap between two keys of one session (or none across sessions).
#include <catch2/catch.hpp>
#include <cstdint>
#include <limits>
#include <unordered_set>

#include "loopd/records/keyframe_key.hpp"
#include "loopd/records/keyframe_record.hpp"

using namespace loopd;

TEST_CASE("keyframe keys order by session, then index, and name 64-bit indices") {
  const KeyframeKey a{0, 5}, b{0, 7}, c{1, 0};
  CHECK(a < b);
  CHECK(b < c);
  CHECK_FALSE(c < a);
  CHECK(a == KeyframeKey{0, 5});
  CHECK(a != b);
  const KeyframeKey far{3, std::int64_t{1} << 40};  // beyond int32: a keyframe index is never narrowed
  CHECK(far.index == 1099511627776LL);
  CHECK(to_string(far) == "3/1099511627776");
}

TEST_CASE("keyframes between two keys: the index gap within a session, unrelated across sessions") {
  CHECK(keyframes_between(KeyframeKey{0, 10}, KeyframeKey{0, 42}) == 32);
  CHECK(keyframes_between(KeyframeKey{2, 10}, KeyframeKey{2, 10}) == 0);
  CHECK(keyframes_between(KeyframeKey{0, 10}, KeyframeKey{1, 11}) == std::numeric_limits<std::int64_t>::max());
}

TEST_CASE("keyframe keys hash apart across sessions and indices") {
  std::unordered_set<KeyframeKey, KeyframeKeyHash> keys;
  for (SessionId s = 0; s < 4; ++s)
    for (std::int64_t i = 0; i < 2000; ++i) keys.insert(KeyframeKey{s, i});
  CHECK(keys.size() == 8000u);
  CHECK(keys.count(KeyframeKey{3, 1999}) == 1u);
  CHECK(keys.count(KeyframeKey{4, 0}) == 0u);
}

TEST_CASE("keyframe features count the descriptor and the prepared scan") {
  KeyframeFeatures f;
  const std::size_t empty = f.bytes();
  f.descriptor = Eigen::VectorXf::Zero(192);
  f.prepared.points.resize(1000);
  CHECK(f.bytes() >= empty + 192 * sizeof(float) + 1000 * sizeof(Eigen::Vector3f));
}
