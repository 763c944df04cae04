#pragma once
/// @file rosbag2's SQLite storage (a ROS 2 bag's .db3 file, the default before Iron): the `topics` table (id, name,
/// type, serialization_format) and the `messages` table (topic_id, timestamp [ns], data), read in time order. The file
/// is opened read-only and never changed; a row with a topic that is not in `topics` is counted and skipped.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

namespace loopd {

/// @brief One row of `topics`.
struct Rosbag2Topic {
  std::int64_t id = 0;
  std::string name;                  ///< e.g. "/ouster/points"
  std::string type;                  ///< e.g. "sensor_msgs/msg/PointCloud2"
  std::string serialization_format;  ///< "cdr"
};

/// @brief Reads one .db3 file.
class Rosbag2SqliteReader {
 public:
  Rosbag2SqliteReader();
  ~Rosbag2SqliteReader();
  /// @brief Opens `path` read-only and reads its topics; false and `error` (naming the file) when it is not a rosbag2
  /// SQLite file.
  bool open(const std::string& path, std::string* error);
  const std::map<std::int64_t, Rosbag2Topic>& topics() const { return topics_; }
  /// @brief Every message in timestamp order (ties by row id); `data` is valid during the call only. False and
  /// `error` when SQLite cannot read the table (a damaged file): what came before was delivered.
  using MessageVisitor = std::function<void(const Rosbag2Topic& topic, std::int64_t timestamp_ns, const std::uint8_t* data, std::size_t size)>;
  bool read(const MessageVisitor& visit, std::string* error);
  std::int64_t orphan_messages() const { return orphan_messages_; }  ///< rows whose topic_id is not in `topics`

 private:
  struct Db;
  std::unique_ptr<Db> db_;
  std::string path_;
  std::map<std::int64_t, Rosbag2Topic> topics_;
  std::int64_t orphan_messages_ = 0;
};

}  // namespace loopd
