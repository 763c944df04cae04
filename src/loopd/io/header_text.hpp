#pragma once
/// @file What the PCD and PLY readers share to parse a text header: an unsigned count with a bound, and where an
///       error is (a header line or a byte offset), for their error messages.
#include <cstddef>
#include <cstdint>
#include <string>

namespace loopd::header_text {

/// @brief Parses the decimal digits of `s` into `*v`; false for anything else, an empty string, or a value over `max`.
inline bool parse_uint(const std::string& s, std::uint64_t max, std::uint64_t* v) {
  if (s.empty() || s.size() > 20) return false;
  std::uint64_t r = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    const auto d = static_cast<std::uint64_t>(c - '0');
    if (r > (max - d) / 10) return false;
    r = r * 10 + d;
  }
  *v = r;
  return true;
}

/// @brief "source:line: ", the prefix of an error in a header line.
inline std::string at_line(const std::string& source, int line) { return source + ":" + std::to_string(line) + ": "; }

/// @brief "source: byte offset N: ", the prefix of an error in the data.
inline std::string at_byte(const std::string& source, std::size_t offset) { return source + ": byte offset " + std::to_string(offset) + ": "; }

}  // namespace loopd::header_text
