#pragma once
/// @file A ROS 2 bag as one stream of messages: a bag folder (metadata.yaml and the .mcap or .db3 files it lists, split
/// bags in the order listed) or a single .mcap or .db3 file. Each message comes with its topic, type and encoding, in
/// time order within each file. ROS-free (io/mcap_reader, io/rosbag2_sqlite); decoding the messages is the caller's
/// (io/ros2_cdr).
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace loopd {

/// @brief One message of a ROS 2 bag (`data` valid during the call only).
struct Ros2BagMessage {
  const std::string* topic = nullptr;
  const std::string* type = nullptr;      ///< e.g. "sensor_msgs/msg/PointCloud2"
  const std::string* encoding = nullptr;  ///< e.g. "cdr"
  std::int64_t time_ns = 0;               ///< when it was recorded [ns since the epoch]
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};

/// @brief A topic's type, encoding and messages read.
struct Ros2BagTopic {
  std::string type, encoding;
  std::int64_t messages = 0;
};

/// @brief Reads a ROS 2 bag.
class Ros2Bag {
 public:
  /// @brief A bag folder or a .mcap / .db3 file; false and `error` (naming the path and what is wrong) otherwise: not a
  /// ROS 2 bag, a file metadata.yaml lists that is missing, a storage or a compression this reader does not know.
  bool open(const std::string& path, std::string* error);
  const std::vector<std::string>& files() const { return files_; }  ///< in the order read
  const std::string& storage() const { return storage_; }           ///< "mcap" or "sqlite3"
  using MessageVisitor = std::function<void(const Ros2BagMessage&)>;
  /// @brief Every message, file by file. False and `error` when a file cannot be read on (the messages before it were
  /// delivered); damage a file's reader skips (MCAP chunks, unknown topics) is counted in skipped() and problems().
  bool read(const MessageVisitor& visit, std::string* error);
  /// @brief Topics seen so far (after read: every topic with its message count).
  const std::map<std::string, Ros2BagTopic>& topics() const { return topics_; }
  std::int64_t skipped() const { return skipped_; }              ///< messages or chunks left out as damaged or orphaned
  const std::string& first_problem() const { return problem_; }  ///< the first of them ("" when none)

 private:
  std::vector<std::string> files_;
  std::string storage_;
  std::map<std::string, Ros2BagTopic> topics_;
  std::int64_t skipped_ = 0;
  std::string problem_;
};

}  // namespace loopd
