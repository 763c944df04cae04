#include "loopd/store/map_cloud_codec.hpp"

#include <zstd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>

namespace loopd {
namespace {

constexpr char kMapCloudMagic[4] = {'L', 'M', 'P', 'C'};
constexpr std::size_t kMapCloudHeaderBytes = 4 + 4 + 4 + 4 + 1 + 4 + 8;
constexpr double kMaxQuantised = 1073741824.0;  // 2^30

void put_le(std::vector<std::uint8_t>* out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out->push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
std::uint64_t get_le(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return v;
}
std::uint32_t float_bits(float f) {
  std::uint32_t b = 0;
  std::memcpy(&b, &f, sizeof b);
  return b;
}
float bits_float(std::uint32_t b) {
  float f = 0.0f;
  std::memcpy(&f, &b, sizeof f);
  return f;
}
void put_varint(std::vector<std::uint8_t>* out, std::int64_t v) {
  std::uint64_t z = (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);  // zig-zag
  while (z >= 0x80) {
    out->push_back(static_cast<std::uint8_t>(z | 0x80));
    z >>= 7;
  }
  out->push_back(static_cast<std::uint8_t>(z));
}

/// Reads zig-zag varints from one stream; the first failure sticks.
struct VarintReader {
  const std::uint8_t* p;
  std::size_t left;
  bool ok = true;
  std::int64_t next() {
    std::uint64_t z = 0;
    for (int shift = 0; shift < 64 && ok; shift += 7) {
      if (left == 0) break;
      const std::uint8_t b = *p++;
      --left;
      z |= static_cast<std::uint64_t>(b & 0x7f) << shift;
      if ((b & 0x80) == 0) return static_cast<std::int64_t>(z >> 1) ^ -static_cast<std::int64_t>(z & 1);
    }
    ok = false;
    return 0;
  }
};

struct Quantised {
  std::array<std::int32_t, 3> q;
  std::uint16_t intensity;
};

}  // namespace

std::vector<std::uint8_t> encode_map_cloud(const PointCloud& cloud, double quantum, int zstd_level) {
  const bool has_i = cloud.has_intensity();
  float scale = 0.0f;
  if (has_i)
    for (float v : cloud.intensity)
      if (std::isfinite(v)) scale = std::max(scale, v);
  std::vector<Quantised> pts;
  pts.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (!p.allFinite()) continue;
    Quantised q{};
    bool fits = true;
    for (int a = 0; a < 3; ++a) {
      const double v = std::round(static_cast<double>(p[a]) / quantum);
      fits = fits && std::abs(v) < kMaxQuantised;
      q.q[static_cast<std::size_t>(a)] = fits ? static_cast<std::int32_t>(v) : 0;
    }
    if (!fits) continue;
    const float iv = has_i && std::isfinite(cloud.intensity[i]) ? std::max(0.0f, cloud.intensity[i]) : 0.0f;
    q.intensity = scale > 0.0f ? static_cast<std::uint16_t>(std::lround(std::min(1.0f, iv / scale) * 65535.0f)) : 0;
    pts.push_back(q);
  }
  std::sort(pts.begin(), pts.end(), [](const Quantised& a, const Quantised& b) { return a.q < b.q; });
  // Four streams, each prefixed by its byte length: x deltas, y deltas, z deltas, intensity deltas.
  std::array<std::vector<std::uint8_t>, 4> streams;
  Quantised prev{};
  for (const Quantised& q : pts) {
    for (std::size_t a = 0; a < 3; ++a) put_varint(&streams[a], static_cast<std::int64_t>(q.q[a]) - prev.q[a]);
    if (has_i) put_varint(&streams[3], static_cast<std::int64_t>(q.intensity) - prev.intensity);
    prev = q;
  }
  std::vector<std::uint8_t> payload;
  for (const auto& s : streams) {
    put_le(&payload, s.size(), 8);
    payload.insert(payload.end(), s.begin(), s.end());
  }
  std::vector<std::uint8_t> out;
  out.insert(out.end(), kMapCloudMagic, kMapCloudMagic + 4);
  put_le(&out, kMapCloudCodecVersion, 4);
  put_le(&out, float_bits(static_cast<float>(quantum)), 4);
  put_le(&out, float_bits(scale), 4);
  out.push_back(has_i ? 1 : 0);
  put_le(&out, pts.size(), 4);
  put_le(&out, payload.size(), 8);
  const std::size_t at = out.size();
  out.resize(at + ZSTD_compressBound(payload.size()));
  const std::size_t n = ZSTD_compress(out.data() + at, out.size() - at, payload.data(), payload.size(), zstd_level);
  out.resize(ZSTD_isError(n) ? at : at + n);  // compressBound always suffices; an error leaves a blob decode refuses
  return out;
}

namespace {

DecodedMapCloud refuse(const std::string& why) {
  DecodedMapCloud d;
  d.error = "map cloud: " + why;
  return d;
}

/// Splits the payload into its four length-prefixed streams; "" or what is wrong.
std::string split_streams(const std::vector<std::uint8_t>& payload, std::array<VarintReader, 4>* streams) {
  std::size_t at = 0;
  for (std::size_t s = 0; s < 4; ++s) {
    if (payload.size() - at < 8) return "stream " + std::to_string(s) + " header past the payload's end";
    const std::uint64_t len = get_le(payload.data() + at, 8);
    at += 8;
    if (len > payload.size() - at) return "stream " + std::to_string(s) + " of " + std::to_string(len) + " bytes past the payload's end";
    (*streams)[s] = VarintReader{payload.data() + at, static_cast<std::size_t>(len)};
    at += static_cast<std::size_t>(len);
  }
  return at == payload.size() ? "" : "trailing bytes after the streams";
}

}  // namespace

std::size_t map_cloud_blob_points(const std::uint8_t* data, std::size_t size) {
  if (data == nullptr || size < kMapCloudHeaderBytes || std::memcmp(data, kMapCloudMagic, 4) != 0) return 0;
  return static_cast<std::size_t>(get_le(data + 17, 4));
}

DecodedMapCloud decode_map_cloud(const std::uint8_t* data, std::size_t size, const MapCloudCodecLimits& limits) {
  if (size < kMapCloudHeaderBytes || data == nullptr) return refuse(std::to_string(size) + " bytes, shorter than its header");
  if (std::memcmp(data, kMapCloudMagic, 4) != 0) return refuse("wrong magic (not a loopd map cloud)");
  const auto version = static_cast<std::uint32_t>(get_le(data + 4, 4));
  if (version != kMapCloudCodecVersion)
    return refuse("version " + std::to_string(version) + ", this loopd reads " + std::to_string(kMapCloudCodecVersion));
  const float quantum = bits_float(static_cast<std::uint32_t>(get_le(data + 8, 4)));
  const float scale = bits_float(static_cast<std::uint32_t>(get_le(data + 12, 4)));
  const bool has_i = data[16] != 0;
  const std::size_t count = static_cast<std::size_t>(get_le(data + 17, 4));
  const std::uint64_t payload_bytes = get_le(data + 21, 8);
  if (!(quantum > 0.0f) || !std::isfinite(quantum) || quantum > 10.0f) return refuse("bad quantum in the header");
  if (!(scale >= 0.0f) || !std::isfinite(scale)) return refuse("bad intensity scale in the header");
  if (data[16] > 1) return refuse("bad intensity flag in the header");
  if (count > limits.max_points) return refuse(std::to_string(count) + " points, over the limit of " + std::to_string(limits.max_points));
  // Each point takes 3 (4 with intensity) varints of 1..10 bytes, plus the four 8-byte stream sizes.
  const std::uint64_t lo = 32 + count * (has_i ? 4u : 3u), hi = 32 + count * (has_i ? 40u : 30u);
  if (payload_bytes < lo || payload_bytes > hi || payload_bytes > limits.max_payload)
    return refuse("payload of " + std::to_string(payload_bytes) + " bytes does not fit " + std::to_string(count) + " points");
  const unsigned long long frame = ZSTD_getFrameContentSize(data + kMapCloudHeaderBytes, size - kMapCloudHeaderBytes);
  if (frame != payload_bytes) return refuse("the zstd frame does not hold the " + std::to_string(payload_bytes) + " bytes the header names");
  std::vector<std::uint8_t> payload(static_cast<std::size_t>(payload_bytes));
  const std::size_t n = ZSTD_decompress(payload.data(), payload.size(), data + kMapCloudHeaderBytes, size - kMapCloudHeaderBytes);
  if (ZSTD_isError(n) || n != payload.size()) return refuse("zstd: the frame does not decompress");
  std::array<VarintReader, 4> streams{};
  if (std::string why = split_streams(payload, &streams); !why.empty()) return refuse(why);
  DecodedMapCloud d;
  d.quantum = quantum;
  d.cloud.points.resize(count);
  if (has_i) d.cloud.intensity.resize(count);
  std::array<std::int64_t, 4> acc{};
  constexpr std::int64_t kMaxAcc = (std::int64_t{1} << 30) - 1;  // what encode can write; sums stay far from overflow
  for (std::size_t i = 0; i < count; ++i) {
    for (std::size_t a = 0; a < (has_i ? 4u : 3u); ++a) {
      const std::int64_t delta = streams[a].next();
      if (delta > kMaxAcc || delta < -kMaxAcc || std::abs(acc[a] + delta) > kMaxAcc)
        return refuse("coordinates out of range at point " + std::to_string(i));
      acc[a] += delta;
    }
    for (std::size_t a = 0; a < 3; ++a) d.cloud.points[i][static_cast<Eigen::Index>(a)] = static_cast<float>(static_cast<double>(acc[a]) * quantum);
    if (has_i) d.cloud.intensity[i] = static_cast<float>(static_cast<double>(acc[3]) / 65535.0 * scale);
  }
  for (std::size_t s = 0; s < 4; ++s)
    if (!streams[s].ok || streams[s].left != 0)
      return refuse("stream " + std::to_string(s) + " does not hold exactly " + std::to_string(count) + " values");
  d.ok = true;
  return d;
}

}  // namespace loopd
