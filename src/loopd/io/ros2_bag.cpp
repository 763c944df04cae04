#include "loopd/io/ros2_bag.hpp"

#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "loopd/io/mcap_reader.hpp"
#include "loopd/io/rosbag2_sqlite.hpp"

namespace loopd {
namespace {

namespace fs = std::filesystem;

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

/// The storage a file's name says ("" when neither).
std::string storage_of(const std::string& file) { return ends_with(file, ".mcap") ? "mcap" : ends_with(file, ".db3") ? "sqlite3" : ""; }

}  // namespace

bool Ros2Bag::open(const std::string& path, std::string* error) {
  const auto fail = [&](const std::string& why) {
    if (error) *error = path + ": " + why;
    return false;
  };
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) {
    storage_ = storage_of(path);
    if (storage_.empty()) return fail("not a ROS 2 bag file (.mcap or .db3)");
    files_ = {path};
    return true;
  }
  if (!fs::is_directory(path, ec)) return fail("no such file or folder");
  const std::string metadata = (fs::path(path) / "metadata.yaml").string();
  if (!fs::is_regular_file(metadata, ec)) return fail("a folder without metadata.yaml (not a ROS 2 bag folder)");
  try {
    const YAML::Node info = YAML::LoadFile(metadata)["rosbag2_bagfile_information"];
    if (!info) return fail("metadata.yaml has no rosbag2_bagfile_information");
    storage_ = info["storage_identifier"] ? info["storage_identifier"].as<std::string>() : "";
    if (storage_ != "mcap" && storage_ != "sqlite3") return fail("storage '" + storage_ + "' (this reader knows mcap and sqlite3)");
    const std::string compression = info["compression_mode"] ? info["compression_mode"].as<std::string>() : "";
    if (!compression.empty() && compression != "NONE")
      return fail("compressed bag (compression_mode " + compression + "): decompress it first (ros2 bag decompress)");
    for (const YAML::Node& file : info["relative_file_paths"]) {
      const std::string full = (fs::path(path) / file.as<std::string>()).string();
      if (!fs::is_regular_file(full, ec)) return fail("metadata.yaml lists " + file.as<std::string>() + ", which is not there");
      files_.push_back(full);
    }
  } catch (const YAML::Exception& e) {
    return fail(std::string("metadata.yaml cannot be read: ") + e.what());
  }
  if (files_.empty()) return fail("metadata.yaml lists no file");
  return true;
}

bool Ros2Bag::read(const MessageVisitor& visit, std::string* error) {
  const auto note = [&](std::int64_t count, const std::string& what) {
    skipped_ += count;
    if (count > 0 && problem_.empty()) problem_ = what;
  };
  for (const std::string& file : files_) {
    if (storage_ == "mcap") {
      McapReader reader;
      if (!reader.open(file, error)) return false;
      const bool ok = reader.read(
          [&](const McapChannel& channel, const McapSchema* schema, const McapMessage& m) {
            Ros2BagTopic& topic = topics_[channel.topic];
            if (topic.type.empty() && schema) topic.type = schema->name;
            topic.encoding = channel.message_encoding;
            ++topic.messages;
            visit({&channel.topic, &topic.type, &topic.encoding, static_cast<std::int64_t>(m.log_time), m.data, m.size});
          },
          error);
      const McapStats& s = reader.stats();
      note(s.chunks_skipped + s.orphan_messages, file + ": " + s.first_problem);
      if (!ok) return false;
    } else {
      Rosbag2SqliteReader reader;
      if (!reader.open(file, error)) return false;
      const bool ok = reader.read(
          [&](const Rosbag2Topic& t, std::int64_t ns, const std::uint8_t* data, std::size_t size) {
            Ros2BagTopic& topic = topics_[t.name];
            topic.type = t.type;
            topic.encoding = t.serialization_format;
            ++topic.messages;
            visit({&t.name, &topic.type, &topic.encoding, ns, data, size});
          },
          error);
      note(reader.orphan_messages(), file + ": messages of a topic its topics table does not hold");
      if (!ok) return false;
    }
  }
  return true;
}

}  // namespace loopd
