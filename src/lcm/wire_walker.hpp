#pragma once
// Internal to src/lcm: the bounds-checking reader of LCM's wire format that bounded_decode and scan_decode share.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

namespace loopd {

/// Walks an LCM wire buffer without allocating: each read checks that the bytes are there. The first failure is kept
/// (reason and offset) and every later read fails, so a layout function can read straight through and test ok() once.
class WireWalker {
 public:
  WireWalker(const void* data, std::size_t size) : bytes_(static_cast<const std::uint8_t*>(data)), size_(size) {}

  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  std::size_t error_offset() const { return error_offset_; }
  std::size_t position() const { return pos_; }
  std::size_t remaining() const { return size_ - pos_; }

  /// Skips `count` elements of `width` bytes (a fixed-size field or array).
  void skip(const char* field, std::size_t width, std::size_t count = 1) {
    if (!ok()) return;
    if (count > remaining() / width)
      return fail(field, "needs " + std::to_string(width * count) + " bytes, " + std::to_string(remaining()) + " left");
    pos_ += width * count;
  }
  std::int64_t int64(const char* field) { return static_cast<std::int64_t>(big_endian(field, 8)); }
  std::int32_t int32(const char* field) { return static_cast<std::int32_t>(static_cast<std::uint32_t>(big_endian(field, 4))); }
  std::int16_t int16(const char* field) { return static_cast<std::int16_t>(static_cast<std::uint16_t>(big_endian(field, 2))); }

  /// An array length field: 0 <= n <= max, and n elements of `width` bytes (times `arrays` arrays sharing it) present.
  std::int64_t length(const char* field, std::int64_t n, std::int64_t max, std::size_t width, int arrays = 1) {
    if (!ok()) return 0;
    const std::size_t at = pos_ - 4;
    if (n < 0) return fail_at(at, field, "= " + std::to_string(n) + " is negative"), 0;
    if (n > max) return fail_at(at, field, "= " + std::to_string(n) + " exceeds the limit " + std::to_string(max)), 0;
    if (static_cast<std::size_t>(n) > remaining() / (width * static_cast<std::size_t>(arrays)))
      return fail_at(at, field,
                     "= " + std::to_string(n) + " needs " + std::to_string(static_cast<std::size_t>(n) * width * static_cast<std::size_t>(arrays)) +
                         " bytes, " + std::to_string(remaining()) + " left"),
             0;
    return n;
  }

  /// The length of an optional per-point array: 0 (absent) or exactly `num_points`, and its elements present.
  std::int64_t optional_length(const char* field, std::int64_t n, std::int64_t num_points, std::size_t width) {
    if (!ok()) return 0;
    if (n != 0 && n != num_points)
      return fail_at(pos_ - 4, field, "= " + std::to_string(n) + " is neither 0 nor num_points (" + std::to_string(num_points) + ")"), 0;
    return length(field, n, num_points, width);
  }

  /// An LCM string: int32 length including the terminating NUL, the bytes, the NUL; no NUL inside.
  void string(const char* field, std::int32_t max_bytes) {
    const std::int32_t n = int32(field);
    if (!ok()) return;
    const std::size_t at = pos_ - 4;
    if (n < 1) return fail_at(at, field, "string length " + std::to_string(n) + " (must be >= 1, counting its NUL)");
    if (n - 1 > max_bytes) return fail_at(at, field, "string of " + std::to_string(n - 1) + " bytes exceeds the limit " + std::to_string(max_bytes));
    if (static_cast<std::size_t>(n) > remaining())
      return fail_at(at, field, "string needs " + std::to_string(n) + " bytes, " + std::to_string(remaining()) + " left");
    const auto* s = bytes_ + pos_;
    if (s[n - 1] != 0) return fail_at(at, field, "string is not NUL-terminated");
    if (std::memchr(s, 0, static_cast<std::size_t>(n - 1)) != nullptr) return fail_at(at, field, "string contains a NUL byte");
    pos_ += static_cast<std::size_t>(n);
  }

  void fingerprint(std::int64_t expected) {
    const std::int64_t h = int64("fingerprint");
    if (ok() && h != expected) fail_at(0, "fingerprint", "does not match the message type (another type, or another version of it)");
  }

  /// Fails at the current position, or at byte `at`; the first failure is kept.
  void fail(const char* field, const std::string& why) { fail_at(pos_, field, why); }
  void fail_at(std::size_t at, const char* field, const std::string& why) {
    if (!ok()) return;
    error_ = std::string(field) + ": " + why;
    error_offset_ = at;
  }

  void end() {
    if (ok() && remaining() != 0) fail("end of message", std::to_string(remaining()) + " trailing bytes");
  }

 private:
  std::uint64_t big_endian(const char* field, std::size_t width) {
    if (!ok()) return 0;
    if (remaining() < width) return fail(field, "needs " + std::to_string(width) + " bytes, " + std::to_string(remaining()) + " left"), 0;
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < width; ++i) v = (v << 8) | bytes_[pos_ + i];
    pos_ += width;
    return v;
  }

  const std::uint8_t* bytes_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::string error_;
  std::size_t error_offset_ = 0;
};

}  // namespace loopd
