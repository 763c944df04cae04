#pragma once
#include <string>

#include "loopd/base/point_cloud.hpp"
#include "loopd/io/cloud_file.hpp"

namespace loopd {

/// @brief Parses a PLY file held in memory (format ascii, binary_little_endian or binary_big_endian; any elements
///        and list properties). Reads x, y, z and, when present, intensity of the `vertex` element; elements before
///        it are walked and skipped, elements after it are ignored. Nothing is allocated from a declared count
///        before the bytes for it are known to be there. On failure returns ok == false with "<source>:<line>: <reason>"
///        (header, ascii data) or "<source>: byte offset <n>: <reason>" (binary data).
CloudFile parse_ply(const std::string& bytes, const std::string& source);

}  // namespace loopd
