#pragma once
#include <string>

#include "loopd/base/point_cloud.hpp"
#include "loopd/io/cloud_file.hpp"

namespace loopd {

/// @brief Parses a PCD file held in memory (versions 0.5-0.7; DATA ascii, binary or binary_compressed; field types
///        I/U/F of 1, 2, 4 or 8 bytes). Reads x, y, z and, when present, intensity. Every header value is checked
///        before anything is allocated: the declared point count must fit in the bytes present (binary), the
///        decompressed size must match the header and LZF's 88x bound (binary_compressed). On failure returns ok ==
///        false with "<source>:<line>: <reason>" (header and ascii data) or "<source>: byte offset <n>: <reason>" (binary).
CloudFile parse_pcd(const std::string& bytes, const std::string& source);

}  // namespace loopd
