#pragma once
// A look at a bag file before rosbag_storage opens it, so that the common ways a recording goes wrong get a plain
// error: not a file, a ROS 2 bag, not a bag, and the ROS 1 v2.0 file header's index position (0: rosbag record was
// stopped before it wrote the index; beyond the end: the file is truncated). Reads the first record only; the bag
// format itself is rosbag_storage's job.
#include <cstdint>
#include <string>

namespace loopd::bag2lcm {

struct BagCheck {
  bool ok = false;
  std::string error;            ///< why the bag cannot be read, naming the file
  std::int64_t file_bytes = 0;  ///< size of the file
  std::string version;          ///< "2.0" (or the version line's text after "#ROSBAG V")
};

/// @brief Checks the file at `path` (never throws; reads at most 4 KiB).
BagCheck check_bag_file(const std::string& path);
/// @brief The same on bytes already read: `head` (the file's first bytes) of a file of `file_bytes` bytes.
BagCheck check_bag_head(const std::string& head, std::int64_t file_bytes, const std::string& path);

}  // namespace loopd::bag2lcm
