// The keyframe codec: features of a real simulated scan come back bit-identical, and damaged or hostile blobs are
// refused with a reason (never a crash, never a huge allocation).
#include <zstd.h>

#include <catch2/catch.hpp>
#include <limits>

#include "loopd/store/keyframe_codec.hpp"
#include "map_test_scene.hpp"

using namespace loopd;
using namespace loopd::map_test;

namespace {

/// @brief A blob with a hand-written payload (what a hostile writer could store).
std::vector<std::uint8_t> blob_of_payload(const std::vector<std::uint8_t>& payload, std::uint32_t version = kKeyframeCodecVersion) {
  std::vector<std::uint8_t> out = {'L', 'K', 'F', 'C'};
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(version >> (8 * i)));
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(static_cast<std::uint64_t>(payload.size()) >> (8 * i)));
  const std::size_t bound = ZSTD_compressBound(payload.size());
  out.resize(16 + bound);
  const std::size_t n = ZSTD_compress(out.data() + 16, bound, payload.data(), payload.size(), 1);
  REQUIRE_FALSE(ZSTD_isError(n));
  out.resize(16 + n);
  return out;
}

void put_u64(std::vector<std::uint8_t>& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

/// The payload prefix of encode_features up to the point count: ok flag, empty error, two timings, two counts.
std::vector<std::uint8_t> payload_head() {
  std::vector<std::uint8_t> p = {1};
  put_u64(p, 0);  // error
  for (int i = 0; i < 4; ++i) put_u64(p, 0);
  return p;
}

KeyframeFeatures small_features() {
  KeyframeFeatures f;
  f.ok = true;
  for (int i = 0; i < 40; ++i) {
    f.prepared.points.emplace_back(0.1f * static_cast<float>(i), -2.5f, 1.f / static_cast<float>(i + 3));
    f.prepared.normals.push_back({static_cast<std::int8_t>(i - 20), 127, -127});
  }
  Cluster c;
  c.num_points = 77;
  c.planar = true;
  c.plane = Eigen::Vector4f(0.f, 0.f, 1.f, -1.8f);
  c.points = {Eigen::Vector3f(1, 2, 3), Eigen::Vector3f(4, 5, 6)};
  c.hull = {Eigen::Vector3f(1, 2, 3)};
  f.prepared.segmentation.clusters.push_back(c);
  return f;
}

}  // namespace

TEST_CASE("keyframe codec: features of simulated HDL-64E scans round-trip bit-identically") {
  for (int i : {0, 17}) {
    const auto f = scan_features(i);
    INFO("scan " << i << ": " << f->prepared.points.size() << " points, " << f->prepared.segmentation.clusters.size() << " clusters");
    REQUIRE(f->prepared.points.size() > 1000);
    REQUIRE(f->prepared.segmentation.clusters.size() > 5);
    REQUIRE(f->prepared.segmentation.num_planar() > 0);
    const std::vector<std::uint8_t> blob = encode_features(*f);
    const DecodedFeatures d = decode_features(blob);
    REQUIRE(d.ok);
    CHECK(d.error.empty());
    require_same_prepared(f->prepared, d.features.prepared);
    CHECK(d.features.descriptor.size() == 0);  // the descriptor has its own column
    KeyframeFeatures with_descriptor = d.features;
    const auto desc_bytes = encode_descriptor(f->descriptor);
    CHECK(desc_bytes.size() == 192 * 4);
    const DecodedDescriptor desc = decode_descriptor(desc_bytes.data(), desc_bytes.size());
    REQUIRE(desc.ok);
    with_descriptor.descriptor = desc.descriptor;
    require_same_feature_fields(*f, with_descriptor);
    // Compressed: smaller than the raw points and normals alone (12 + 3 bytes a point).
    WARN("scan " << i << ": " << blob.size() << " bytes for " << f->prepared.points.size() << " points and "
                 << f->prepared.segmentation.clusters.size() << " clusters");
    CHECK(blob.size() < f->prepared.points.size() * 15);
  }
}

TEST_CASE("keyframe codec: special floats, unusable features and empty scans keep their exact bits") {
  KeyframeFeatures f = small_features();
  f.ok = false;
  f.error = "scan has 0 finite points";
  f.prepared.error = "empty";
  f.prepared.segmentation.error = "no rings";
  f.ms_descriptor = -0.0;
  f.ms_prepare = std::numeric_limits<double>::denorm_min();
  f.prepared.points[0] = Eigen::Vector3f(std::numeric_limits<float>::quiet_NaN(), -0.f, std::numeric_limits<float>::infinity());
  f.prepared.points[1].x() = std::numeric_limits<float>::denorm_min();
  f.prepared.input_points = std::numeric_limits<std::size_t>::max();
  f.descriptor = Eigen::VectorXf::Constant(3, -0.f);
  f.descriptor[1] = std::numeric_limits<float>::quiet_NaN();
  const DecodedFeatures d = decode_features(encode_features(f));
  REQUIRE(d.ok);
  require_same_prepared(f.prepared, d.features.prepared);
  CHECK(!d.features.ok);
  CHECK(d.features.error == f.error);
  CHECK(same_bits(d.features.ms_descriptor, f.ms_descriptor));
  CHECK(same_bits(d.features.ms_prepare, f.ms_prepare));
  const auto desc_bytes = encode_descriptor(f.descriptor);
  const DecodedDescriptor desc = decode_descriptor(desc_bytes.data(), desc_bytes.size());
  REQUIRE(desc.ok);
  CHECK(same_descriptor(desc.descriptor, f.descriptor));

  const DecodedFeatures empty = decode_features(encode_features(KeyframeFeatures{}));
  REQUIRE(empty.ok);
  CHECK(empty.features.prepared.points.empty());
  CHECK(empty.features.prepared.segmentation.clusters.empty());
}

TEST_CASE("keyframe codec: every truncation and every single bit flip of a blob is refused with a reason") {
  const std::vector<std::uint8_t> blob = encode_features(small_features());
  REQUIRE(decode_features(blob).ok);
  for (std::size_t n = 0; n < blob.size(); ++n) {
    const DecodedFeatures d = decode_features(blob.data(), n);
    INFO("first " << n << " of " << blob.size() << " bytes");
    CHECK_FALSE(d.ok);
    CHECK(d.error.find("keyframe features") == 0);
  }
  int refused = 0, unchanged = 0, flips = 0;
  for (std::size_t byte = 0; byte < blob.size(); ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<std::uint8_t> bad = blob;
      bad[byte] ^= static_cast<std::uint8_t>(1u << bit);
      const DecodedFeatures d = decode_features(bad);
      ++flips;
      if (!d.ok && !d.error.empty()) ++refused;
      // A few bits of zstd's frame and block headers do not change what they decode to.
      if (d.ok && encode_features(d.features) == blob) ++unchanged;
    }
  }
  // The frame carries a checksum: no flip decodes into other numbers.
  INFO(flips << " flips: " << refused << " refused, " << unchanged << " decode to the same features");
  CHECK(refused + unchanged == flips);
  CHECK(refused > flips * 95 / 100);
  std::vector<std::uint8_t> with_tail = blob;
  with_tail.push_back(0);
  const DecodedFeatures tail = decode_features(with_tail);
  CHECK_FALSE(tail.ok);
  CHECK(tail.error.find("after the zstd frame") != std::string::npos);
}

TEST_CASE("keyframe codec: a wrong magic or version is refused and named") {
  std::vector<std::uint8_t> blob = encode_features(small_features());
  blob[4] = 2;
  const DecodedFeatures v = decode_features(blob);
  CHECK_FALSE(v.ok);
  CHECK(v.error == "keyframe features: codec version 2 at byte 4, this loopd reads 1");
  blob[0] = 'X';
  const DecodedFeatures m = decode_features(blob);
  CHECK_FALSE(m.ok);
  CHECK(m.error.find("bad magic") != std::string::npos);
}

TEST_CASE("keyframe codec: hostile counts are refused before anything is allocated for them") {
  SECTION("2^40 points in a short payload") {
    std::vector<std::uint8_t> p = payload_head();
    put_u64(p, 1ull << 40);
    const DecodedFeatures d = decode_features(blob_of_payload(p));
    CHECK_FALSE(d.ok);
    CHECK(d.error.find("points 1099511627776 over the limit") != std::string::npos);
  }
  SECTION("a count under the cap that the bytes left cannot hold") {
    std::vector<std::uint8_t> p = payload_head();
    put_u64(p, 1000);  // 12,000 bytes of points announced, none follow
    const DecodedFeatures d = decode_features(blob_of_payload(p));
    CHECK_FALSE(d.ok);
    CHECK(d.error.find("points 1000 do not fit the 0 bytes left at payload byte") != std::string::npos);
  }
  SECTION("a stated payload size over the limit") {
    std::vector<std::uint8_t> blob = blob_of_payload(payload_head());
    blob[15] = 0x7f;
    const DecodedFeatures d = decode_features(blob);
    CHECK_FALSE(d.ok);
    CHECK(d.error.find("over the limit") != std::string::npos);
  }
  SECTION("a frame that decompresses to more than the stated size") {
    std::vector<std::uint8_t> blob = blob_of_payload(std::vector<std::uint8_t>(100000, 0));
    blob[8] = 10;  // states 10 + 256 * x bytes: far fewer than the 100000 in the frame
    for (int i = 9; i < 16; ++i) blob[static_cast<std::size_t>(i)] = 0;
    const DecodedFeatures d = decode_features(blob);
    CHECK_FALSE(d.ok);
    CHECK(d.error.find("larger than its stated 10 bytes") != std::string::npos);
  }
  SECTION("a flag that is neither 0 nor 1") {
    std::vector<std::uint8_t> p = payload_head();
    p[0] = 7;
    const DecodedFeatures d = decode_features(blob_of_payload(p));
    CHECK_FALSE(d.ok);
    CHECK(d.error.find("bad features ok flag 7 at payload byte 1") != std::string::npos);
  }
}

TEST_CASE("keyframe codec: descriptor bytes are raw little-endian float32, and a ragged size is refused") {
  Eigen::VectorXf d(2);
  d << 1.0f, -2.0f;
  const auto bytes = encode_descriptor(d);
  const std::vector<std::uint8_t> expected = {0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0xc0};
  CHECK(bytes == expected);
  const DecodedDescriptor ragged = decode_descriptor(bytes.data(), 7);
  CHECK_FALSE(ragged.ok);
  CHECK(ragged.error.find("7 bytes is not a whole number of float32 values") != std::string::npos);
  const DecodedDescriptor empty = decode_descriptor(nullptr, 0);
  CHECK(empty.ok);
  CHECK(empty.descriptor.size() == 0);
}
