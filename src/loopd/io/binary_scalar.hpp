#pragma once
// Scalar types of PCD and PLY fields, and reading one from raw bytes (any alignment, either byte order) as float.
#include <cstdint>
#include <cstring>
#include <string>

namespace loopd {

/// @brief A fixed-size number type of a cloud file field.
enum class ScalarType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kInt64, kUint64, kFloat32, kFloat64 };

/// @brief True for the integer types (every type but kFloat32 and kFloat64).
inline bool is_integer(ScalarType t) { return t != ScalarType::kFloat32 && t != ScalarType::kFloat64; }

/// @brief Bytes of one value of `t`.
inline int scalar_size(ScalarType t) {
  switch (t) {
    case ScalarType::kInt8:
    case ScalarType::kUint8:
      return 1;
    case ScalarType::kInt16:
    case ScalarType::kUint16:
      return 2;
    case ScalarType::kInt32:
    case ScalarType::kUint32:
    case ScalarType::kFloat32:
      return 4;
    default:
      return 8;
  }
}

/// @brief Reads one value at `p` (scalar_size(t) bytes) as float; `big_endian` for PLY's binary_big_endian.
inline float read_scalar_as_float(const unsigned char* p, ScalarType t, bool big_endian) {
  unsigned char b[8];
  const int n = scalar_size(t);
  for (int i = 0; i < n; ++i) b[i] = big_endian ? p[n - 1 - i] : p[i];  // the host is little-endian (x86-64, aarch64)
  switch (t) {
    case ScalarType::kInt8: {
      std::int8_t v;
      std::memcpy(&v, b, 1);
      return static_cast<float>(v);
    }
    case ScalarType::kUint8:
      return static_cast<float>(b[0]);
    case ScalarType::kInt16: {
      std::int16_t v;
      std::memcpy(&v, b, 2);
      return static_cast<float>(v);
    }
    case ScalarType::kUint16: {
      std::uint16_t v;
      std::memcpy(&v, b, 2);
      return static_cast<float>(v);
    }
    case ScalarType::kInt32: {
      std::int32_t v;
      std::memcpy(&v, b, 4);
      return static_cast<float>(v);
    }
    case ScalarType::kUint32: {
      std::uint32_t v;
      std::memcpy(&v, b, 4);
      return static_cast<float>(v);
    }
    case ScalarType::kInt64: {
      std::int64_t v;
      std::memcpy(&v, b, 8);
      return static_cast<float>(v);
    }
    case ScalarType::kUint64: {
      std::uint64_t v;
      std::memcpy(&v, b, 8);
      return static_cast<float>(v);
    }
    case ScalarType::kFloat32: {
      float v;
      std::memcpy(&v, b, 4);
      return v;
    }
    case ScalarType::kFloat64: {
      double v;
      std::memcpy(&v, b, 8);
      // A double beyond float's range becomes +-inf (a plain cast would be undefined behaviour).
      if (v > 3.4028234e38) return __builtin_huge_valf();
      if (v < -3.4028234e38) return -__builtin_huge_valf();
      return static_cast<float>(v);
    }
  }
  return 0.f;
}

/// @brief Parses a decimal number token of a text cloud file as float ("nan"/"inf" accepted, values beyond float's
///        range become +-inf). False when the token is not a number.
bool parse_float_token(const std::string& token, float* value);

}  // namespace loopd
