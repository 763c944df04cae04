#include "loopd/store/keyframe_codec.hpp"

#include <zstd.h>

#include <cstring>
#include <new>
#include <type_traits>

namespace loopd {
namespace {

constexpr char kKeyframeMagic[4] = {'L', 'K', 'F', 'C'};
constexpr std::size_t kKeyframeHeaderBytes = 16;  // magic, u32 version, u64 payload bytes

/// @brief Little-endian writer of the payload.
class Writer {
 public:
  void u8(std::uint8_t v) { out_.push_back(v); }
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void u64(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void f32(float v) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    u32(bits);
  }
  void f64(double v) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    u64(bits);
  }
  void size(std::size_t n) { u64(static_cast<std::uint64_t>(n)); }
  void str(const std::string& s) {
    size(s.size());
    out_.insert(out_.end(), s.begin(), s.end());
  }
  void vec3(const Eigen::Vector3f& v) {
    f32(v.x());
    f32(v.y());
    f32(v.z());
  }
  /// Count, then the 3n floats' bits as four byte planes (all lowest bytes first): exponent and sign bytes of nearby
  /// points repeat, so zstd finds them (a byte shuffle; the bits are unchanged).
  void points(const std::vector<Eigen::Vector3f>& pts) {
    size(pts.size());
    const std::size_t floats = 3 * pts.size();
    const std::size_t at = out_.size();
    out_.resize(at + 4 * floats);
    for (std::size_t k = 0; k < floats; ++k) {
      std::uint32_t bits = 0;
      std::memcpy(&bits, &pts[k / 3][static_cast<Eigen::Index>(k % 3)], sizeof bits);
      for (std::size_t b = 0; b < 4; ++b) out_[at + b * floats + k] = static_cast<std::uint8_t>(bits >> (8 * b));
    }
  }
  std::vector<std::uint8_t>& bytes() { return out_; }

 private:
  std::vector<std::uint8_t> out_;
};

/// @brief Little-endian reader that checks every read and every count against the bytes left; the first failure
/// sticks (later reads return zeros) and names the field and byte offset.
class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  std::size_t left() const { return size_ - pos_; }
  std::size_t pos() const { return pos_; }

  void fail(const std::string& what) {
    if (error_.empty()) error_ = what + " at payload byte " + std::to_string(pos_);
  }
  bool take(std::size_t n, const char* field) {
    if (!ok()) return false;
    if (n > left()) {
      fail(std::string("truncated ") + field + " (needs " + std::to_string(n) + " bytes, " + std::to_string(left()) + " left)");
      return false;
    }
    return true;
  }
  std::uint64_t uint(int bytes, const char* field) {
    if (!take(static_cast<std::size_t>(bytes), field)) return 0;
    std::uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(data_[pos_ + static_cast<std::size_t>(i)]) << (8 * i);
    pos_ += static_cast<std::size_t>(bytes);
    return v;
  }
  std::uint8_t u8(const char* field) { return static_cast<std::uint8_t>(uint(1, field)); }
  std::int32_t i32(const char* field) { return static_cast<std::int32_t>(static_cast<std::uint32_t>(uint(4, field))); }
  float f32(const char* field) {
    const auto bits = static_cast<std::uint32_t>(uint(4, field));
    float v = 0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  double f64(const char* field) {
    const std::uint64_t bits = uint(8, field);
    double v = 0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  bool flag(const char* field) {
    const std::uint8_t v = u8(field);
    if (v > 1) fail(std::string("bad ") + field + " flag " + std::to_string(v));
    return v == 1;
  }
  /// A count of elements of `element_bytes` each: refused when over `cap` or when the elements cannot fit the bytes left.
  std::size_t count(std::size_t element_bytes, std::size_t cap, const char* field) {
    const std::uint64_t n = uint(8, field);
    if (!ok()) return 0;
    if (n > cap) {
      fail(std::string(field) + " " + std::to_string(n) + " over the limit " + std::to_string(cap));
      return 0;
    }
    if (element_bytes > 0 && n > left() / element_bytes) {
      fail(std::string(field) + " " + std::to_string(n) + " do not fit the " + std::to_string(left()) + " bytes left");
      return 0;
    }
    return static_cast<std::size_t>(n);
  }
  std::string str(std::size_t cap, const char* field) {
    const std::size_t n = count(1, cap, field);
    if (!ok() || n == 0) return {};
    std::string s(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return s;
  }
  Eigen::Vector3f vec3(const char* field) {
    const float x = f32(field), y = f32(field), z = f32(field);
    return {x, y, z};
  }
  /// The inverse of Writer::points.
  std::vector<Eigen::Vector3f> points(std::size_t cap, const char* field) {
    std::vector<Eigen::Vector3f> out(count(12, cap, field));
    const std::size_t floats = 3 * out.size();
    if (!ok() || floats == 0) return out;
    for (std::size_t k = 0; k < floats; ++k) {
      std::uint32_t bits = 0;
      for (std::size_t b = 0; b < 4; ++b) bits |= static_cast<std::uint32_t>(data_[pos_ + b * floats + k]) << (8 * b);
      std::memcpy(&out[k / 3][static_cast<Eigen::Index>(k % 3)], &bits, sizeof bits);
    }
    pos_ += 4 * floats;
    return out;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::string error_;
};

void write_cluster(Writer& w, const Cluster& c) {
  w.vec3(c.centroid);
  w.i32(c.num_points);
  w.u8(c.planar ? 1 : 0);
  for (int i = 0; i < 4; ++i) w.f32(c.plane[i]);
  w.points(c.points);
  w.points(c.hull);
  w.f32(c.extent_major);
  w.f32(c.extent_minor);
}

Cluster read_cluster(Reader& r, const KeyframeCodecLimits& limits) {
  Cluster c;
  c.centroid = r.vec3("cluster centroid");
  c.num_points = r.i32("cluster num_points");
  c.planar = r.flag("cluster planar");
  for (int i = 0; i < 4; ++i) c.plane[i] = r.f32("cluster plane");
  c.points = r.points(limits.max_cluster_points, "cluster points");
  c.hull = r.points(limits.max_cluster_points, "cluster hull vertices");
  c.extent_major = r.f32("cluster extent_major");
  c.extent_minor = r.f32("cluster extent_minor");
  return c;
}

/// @brief The uncompressed payload: features' own fields, then the prepared scan, then its segmentation.
std::vector<std::uint8_t> write_payload(const KeyframeFeatures& f) {
  Writer w;
  w.u8(f.ok ? 1 : 0);
  w.str(f.error);
  w.f64(f.ms_descriptor);
  w.f64(f.ms_prepare);
  w.size(f.input_points);
  w.size(f.invalid_points);
  const PreparedScan& p = f.prepared;
  w.points(p.points);
  w.size(p.normals.size());
  for (const PackedNormal& n : p.normals) {
    w.u8(static_cast<std::uint8_t>(n.x));
    w.u8(static_cast<std::uint8_t>(n.y));
    w.u8(static_cast<std::uint8_t>(n.z));
  }
  w.size(p.input_points);
  w.size(p.finite_points);
  w.f64(p.ms_segmentation);
  w.f64(p.ms_total);
  w.str(p.error);
  const Segmentation& s = p.segmentation;
  w.str(s.error);
  w.f64(s.ms);
  w.size(s.clusters.size());
  for (const Cluster& c : s.clusters) write_cluster(w, c);
  return std::move(w.bytes());
}

void read_prepared(Reader& r, PreparedScan& p, const KeyframeCodecLimits& limits) {
  p.points = r.points(limits.max_points, "points");
  p.normals.resize(r.count(3, limits.max_points, "normals"));
  for (PackedNormal& n : p.normals) {
    n.x = static_cast<std::int8_t>(r.u8("normal"));
    n.y = static_cast<std::int8_t>(r.u8("normal"));
    n.z = static_cast<std::int8_t>(r.u8("normal"));
  }
  p.input_points = static_cast<std::size_t>(r.uint(8, "prepared input_points"));
  p.finite_points = static_cast<std::size_t>(r.uint(8, "prepared finite_points"));
  p.ms_segmentation = r.f64("ms_segmentation");
  p.ms_total = r.f64("ms_total");
  p.error = r.str(limits.max_string, "prepared error");
  Segmentation& s = p.segmentation;
  s.error = r.str(limits.max_string, "segmentation error");
  s.ms = r.f64("segmentation ms");
  // The smallest cluster (no points, no hull) is 57 bytes.
  const std::size_t clusters = r.count(57, limits.max_clusters, "clusters");
  s.clusters.reserve(clusters);
  for (std::size_t i = 0; i < clusters && r.ok(); ++i) s.clusters.push_back(read_cluster(r, limits));
}

DecodedFeatures read_payload(const std::uint8_t* data, std::size_t size, const KeyframeCodecLimits& limits) {
  DecodedFeatures out;
  Reader r(data, size);
  KeyframeFeatures& f = out.features;
  f.ok = r.flag("features ok");
  f.error = r.str(limits.max_string, "features error");
  f.ms_descriptor = r.f64("ms_descriptor");
  f.ms_prepare = r.f64("ms_prepare");
  f.input_points = static_cast<std::size_t>(r.uint(8, "input_points"));
  f.invalid_points = static_cast<std::size_t>(r.uint(8, "invalid_points"));
  read_prepared(r, f.prepared, limits);
  if (r.ok() && r.left() != 0) r.fail(std::to_string(r.left()) + " trailing bytes");
  if (!r.ok()) {
    out.error = "keyframe features: " + r.error();
    out.features = KeyframeFeatures{};
    return out;
  }
  out.ok = true;
  return out;
}

std::uint64_t read_le(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return v;
}

/// @brief Streams the zstd frame into at most `expected` bytes, growing the buffer only as output is produced (a
/// hostile size field cannot make it allocate what the frame does not hold). Empty string on success, else why.
std::string decompress(const std::uint8_t* data, std::size_t size, std::size_t expected, std::vector<std::uint8_t>& out) {
  ZSTD_DStream* ds = ZSTD_createDStream();
  if (!ds) return "zstd: out of memory";
  ZSTD_initDStream(ds);
  out.assign(std::min<std::size_t>(expected, 1u << 16), 0);
  ZSTD_inBuffer in{data, size, 0};
  ZSTD_outBuffer ob{out.data(), out.size(), 0};
  std::string error;
  std::size_t ret = 1;
  while (true) {
    ret = ZSTD_decompressStream(ds, &ob, &in);
    if (ZSTD_isError(ret)) {
      error = std::string("zstd: ") + ZSTD_getErrorName(ret);
      break;
    }
    if (ret == 0) break;  // frame complete
    if (ob.pos == ob.size) {
      if (out.size() >= expected) {
        error = "payload larger than its stated " + std::to_string(expected) + " bytes";
        break;
      }
      out.resize(std::min(expected, 2 * out.size()));
      ob.dst = out.data();
      ob.size = out.size();
      continue;
    }
    if (in.pos == in.size) {
      error = "zstd: truncated frame";
      break;
    }
  }
  ZSTD_freeDStream(ds);
  if (error.empty() && in.pos != in.size) error = std::to_string(in.size - in.pos) + " bytes after the zstd frame";
  if (error.empty() && ob.pos != expected) error = "payload is " + std::to_string(ob.pos) + " bytes, stated " + std::to_string(expected);
  out.resize(ob.pos);
  return error;
}

}  // namespace

std::vector<std::uint8_t> encode_features(const KeyframeFeatures& features, int zstd_level) {
  const std::vector<std::uint8_t> payload = write_payload(features);
  Writer header;
  for (char c : kKeyframeMagic) header.u8(static_cast<std::uint8_t>(c));
  header.u32(kKeyframeCodecVersion);
  header.size(payload.size());
  std::vector<std::uint8_t> out = std::move(header.bytes());
  const std::size_t bound = ZSTD_compressBound(payload.size());
  out.resize(kKeyframeHeaderBytes + bound);
  // With a content checksum (4 bytes): a flipped bit anywhere in the frame is refused, not decoded into other numbers.
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, zstd_level);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 1);
  std::size_t n = 0;
  if (cctx) {
    n = ZSTD_compress2(cctx, out.data() + kKeyframeHeaderBytes, bound, payload.data(), payload.size());
    if (ZSTD_isError(n)) n = 0;
  }
  ZSTD_freeCCtx(cctx);
  // Fails only without memory (the bound rules out a short buffer): the blob then holds no frame and decodes as damaged.
  out.resize(kKeyframeHeaderBytes + n);
  return out;
}

DecodedFeatures decode_features(const std::uint8_t* data, std::size_t size, const KeyframeCodecLimits& limits) {
  DecodedFeatures out;
  try {
    if (size < kKeyframeHeaderBytes) {
      out.error = "keyframe features: " + std::to_string(size) + " bytes, shorter than the " + std::to_string(kKeyframeHeaderBytes) + "-byte header";
      return out;
    }
    if (std::memcmp(data, kKeyframeMagic, 4) != 0) {
      out.error = "keyframe features: bad magic at byte 0 (not a loopd keyframe blob)";
      return out;
    }
    const auto version = static_cast<std::uint32_t>(read_le(data + 4, 4));
    if (version != kKeyframeCodecVersion) {
      out.error =
          "keyframe features: codec version " + std::to_string(version) + " at byte 4, this loopd reads " + std::to_string(kKeyframeCodecVersion);
      return out;
    }
    const std::uint64_t payload_bytes = read_le(data + 8, 8);
    if (payload_bytes > limits.max_payload) {
      out.error = "keyframe features: payload of " + std::to_string(payload_bytes) + " bytes at byte 8 is over the limit " +
                  std::to_string(limits.max_payload);
      return out;
    }
    std::vector<std::uint8_t> payload;
    const std::string error = decompress(data + kKeyframeHeaderBytes, size - kKeyframeHeaderBytes, static_cast<std::size_t>(payload_bytes), payload);
    if (!error.empty()) {
      out.error = "keyframe features: " + error + " (compressed payload from byte " + std::to_string(kKeyframeHeaderBytes) + ")";
      return out;
    }
    return read_payload(payload.data(), payload.size(), limits);
  } catch (const std::bad_alloc&) {
    out = DecodedFeatures{};
    out.error = "keyframe features: out of memory";
    return out;
  }
}

std::vector<std::uint8_t> encode_descriptor(const Eigen::VectorXf& descriptor) {
  Writer w;
  for (Eigen::Index i = 0; i < descriptor.size(); ++i) w.f32(descriptor[i]);
  return std::move(w.bytes());
}

DecodedDescriptor decode_descriptor(const std::uint8_t* data, std::size_t size, const KeyframeCodecLimits& limits) {
  DecodedDescriptor out;
  if (size % 4 != 0) {
    out.error = "descriptor: " + std::to_string(size) + " bytes is not a whole number of float32 values";
    return out;
  }
  if (size / 4 > limits.max_descriptor) {
    out.error = "descriptor: " + std::to_string(size / 4) + " values over the limit " + std::to_string(limits.max_descriptor);
    return out;
  }
  Reader r(data, size);
  out.descriptor.resize(static_cast<Eigen::Index>(size / 4));
  for (Eigen::Index i = 0; i < out.descriptor.size(); ++i) out.descriptor[i] = r.f32("descriptor");
  out.ok = true;
  return out;
}

}  // namespace loopd
