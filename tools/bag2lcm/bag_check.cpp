#include "bag_check.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace loopd::bag2lcm {
namespace {

constexpr const char* kReindexHint = "; `rosbag reindex` (python3-rosbag) may recover the messages before the damage";

std::uint64_t little_endian(const std::string& s, std::size_t pos, std::size_t bytes) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(static_cast<unsigned char>(s[pos + i])) << (8 * i);
  return v;
}

/// The value of field `name` in the header record's fields [begin, end), or "" (each field: u32 length, name=value).
std::string header_field(const std::string& head, std::size_t begin, std::size_t end, const std::string& name) {
  std::size_t pos = begin;
  while (pos + 4 <= end) {
    const std::uint64_t len = little_endian(head, pos, 4);
    pos += 4;
    if (len > end - pos) break;
    const std::string field = head.substr(pos, static_cast<std::size_t>(len));
    pos += static_cast<std::size_t>(len);
    if (field.size() > name.size() && field.compare(0, name.size(), name) == 0 && field[name.size()] == '=') return field.substr(name.size() + 1);
  }
  return "";
}

}  // namespace

BagCheck check_bag_head(const std::string& head, std::int64_t file_bytes, const std::string& path) {
  BagCheck c;
  c.file_bytes = file_bytes;
  const std::string magic = "#ROSBAG V";
  if (head.compare(0, 16, std::string("SQLite format 3\0", 16)) == 0) {
    c.error = path + ": a ROS 2 bag (sqlite3); bag2lcm reads ROS 1 bags (convert with the rosbags tools first)";
    return c;
  }
  if (head.size() < magic.size() || head.compare(0, magic.size(), magic) != 0) {
    c.error = path + ": not a ROS 1 bag (no '#ROSBAG V' version line at the start)";
    return c;
  }
  const std::size_t eol = head.find('\n');
  c.version = head.substr(magic.size(), eol == std::string::npos ? std::string::npos : eol - magic.size());
  if (c.version != "2.0") {  // 1.2 bags: rosbag_storage reads them, without this header to check
    c.ok = eol != std::string::npos;
    if (!c.ok) c.error = path + ": the bag's version line is cut off";
    return c;
  }
  // The bag header record follows the version line: u32 header length, the header's fields, u32 data length.
  const std::size_t start = eol + 1;
  if (head.size() < start + 4) {
    c.error = path + ": the file ends after its version line (" + std::to_string(file_bytes) + " bytes): truncated";
    return c;
  }
  const std::uint64_t header_len = little_endian(head, start, 4);
  if (header_len > head.size() - start - 4) {
    c.error = path + ": the bag header record (" + std::to_string(header_len) + " bytes) is cut off or damaged";
    return c;
  }
  const std::string index_pos = header_field(head, start + 4, start + 4 + static_cast<std::size_t>(header_len), "index_pos");
  if (index_pos.size() != 8) {
    c.error = path + ": the bag header record has no index_pos field: damaged";
    return c;
  }
  const std::uint64_t index = little_endian(index_pos, 0, 8);
  if (index == 0) {
    c.error = path + ": the bag has no index (rosbag record was stopped before it closed the bag)" + kReindexHint;
  } else if (index >= static_cast<std::uint64_t>(file_bytes)) {
    c.error = path + ": truncated: the file has " + std::to_string(file_bytes) + " bytes but its index starts at byte " + std::to_string(index) +
              kReindexHint;
  } else {
    c.ok = true;
  }
  return c;
}

BagCheck check_bag_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    BagCheck c;
    c.error = path + ": a folder (a ROS 2 bag?); bag2lcm reads ROS 1 .bag files";
    return c;
  }
  std::ifstream in(path, std::ios::binary);
  const auto size = static_cast<std::int64_t>(std::filesystem::file_size(path, ec));
  if (!in || ec) {
    BagCheck c;
    c.error = path + ": cannot open (" + (ec ? ec.message() : std::string(std::strerror(errno))) + ")";
    return c;
  }
  std::string head(4096, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return check_bag_head(head, size, path);
}

}  // namespace loopd::bag2lcm
