// ROS 2 bags as one stream (src/loopd/io/ros2_bag): a split .db3 bag folder read file after file, a single .db3 file,
// an MCAP bag written by @mcap/core (npm), and what is not a bag refused with the path and the reason.
#include <catch2/catch.hpp>

#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "loopd/io/ros2_bag.hpp"
#include "support/npm_tools.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {

/// A .db3 with rosbag2's tables: one topic, messages "<tag>0".."<tag>{n-1}" at times t0, t0 + 1, ...
void write_db3(const std::string& path, const std::string& topic, const std::string& tag, int n, std::int64_t t0) {
  fs::remove(path);
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(path.c_str(), &db) == SQLITE_OK);
  std::string sql =
      "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, serialization_format TEXT NOT NULL,"
      " offered_qos_profiles TEXT NOT NULL);"
      "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
      "INSERT INTO topics VALUES (1, '" +
      topic + "', 'nav_msgs/msg/Odometry', 'cdr', '');";
  for (int i = 0; i < n; ++i)
    sql += "INSERT INTO messages(topic_id, timestamp, data) VALUES (1, " + std::to_string(t0 + i) + ", '" + tag + std::to_string(i) + "');";
  REQUIRE(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr) == SQLITE_OK);
  sqlite3_close(db);
}

std::vector<std::string> read_all(Ros2Bag& bag) {
  std::vector<std::string> out;
  std::string error;
  REQUIRE(
      bag.read([&](const Ros2BagMessage& m) { out.push_back(*m.topic + " " + std::string(reinterpret_cast<const char*>(m.data), m.size)); }, &error));
  return out;
}

}  // namespace

TEST_CASE("ROS 2 bag: a split .db3 bag folder is read file after file in metadata.yaml's order, a single .db3 file alone") {
  const fs::path dir = fs::temp_directory_path() / ("loopd_ros2_bag_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_db3((dir / "drive_0.db3").string(), "/odom", "a", 3, 100);
  write_db3((dir / "drive_1.db3").string(), "/odom", "b", 2, 200);
  std::ofstream(dir / "metadata.yaml") << "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
                                          "  relative_file_paths:\n    - drive_0.db3\n    - drive_1.db3\n  compression_format: \"\"\n"
                                          "  compression_mode: \"\"\n";
  Ros2Bag bag;
  std::string error;
  REQUIRE(bag.open(dir.string(), &error));
  CHECK(bag.storage() == "sqlite3");
  CHECK(bag.files().size() == 2);
  CHECK(read_all(bag) == std::vector<std::string>{"/odom a0", "/odom a1", "/odom a2", "/odom b0", "/odom b1"});
  REQUIRE(bag.topics().count("/odom") == 1);
  CHECK(bag.topics().at("/odom").messages == 5);
  CHECK(bag.topics().at("/odom").type == "nav_msgs/msg/Odometry");
  CHECK(bag.skipped() == 0);

  Ros2Bag single;
  REQUIRE(single.open((dir / "drive_1.db3").string(), &error));
  CHECK(read_all(single) == std::vector<std::string>{"/odom b0", "/odom b1"});
  fs::remove_all(dir);
}

TEST_CASE("ROS 2 bag: what is not a bag, a missing split file, a compressed bag and an unknown storage are refused with the reason") {
  const fs::path dir = fs::temp_directory_path() / ("loopd_ros2_bag_bad_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const auto refused = [&](const std::string& path, const std::string& why) {
    Ros2Bag bag;
    std::string error;
    INFO(path);
    CHECK_FALSE(bag.open(path, &error));
    CHECK(error.find(path) == 0);
    CHECK(error.find(why) != std::string::npos);
  };
  refused(dir.string(), "without metadata.yaml");
  refused((dir / "nothing").string(), "no such file or folder");
  std::ofstream(dir / "drive.bag") << "#ROSBAG V2.0";
  refused((dir / "drive.bag").string(), "not a ROS 2 bag file");
  const auto metadata = [&](const std::string& body) { std::ofstream(dir / "metadata.yaml") << "rosbag2_bagfile_information:\n" << body; };
  metadata("  storage_identifier: sqlite3\n  relative_file_paths: [gone.db3]\n");
  refused(dir.string(), "lists gone.db3, which is not there");
  metadata("  storage_identifier: sqlite3\n  relative_file_paths: [drive.bag]\n  compression_mode: FILE\n");
  refused(dir.string(), "compressed bag");
  metadata("  storage_identifier: rosbag_v2\n  relative_file_paths: [drive.bag]\n");
  refused(dir.string(), "storage 'rosbag_v2'");
  metadata("  storage_identifier: [not, text\n");
  refused(dir.string(), "metadata.yaml cannot be read");
  fs::remove_all(dir);
}

TEST_CASE("ROS 2 bag: an MCAP bag folder of files written by @mcap/core (npm)") {
  if (!loopd::test::npm_tools({"@mcap/core@2.2.2", "lz4js@0.2.0"}, {"zstd"})) {
    WARN("skipped: node, npm, zstd or the npm registry (@mcap/core, lz4js) is not available");
    return;
  }
  const fs::path dir = fs::temp_directory_path() / ("loopd_ros2_bag_mcap_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  REQUIRE(loopd::test::run_node("io/npm/write_mcap.mjs", (dir / "bag_0.mcap").string() + " zstd") == 0);
  REQUIRE(loopd::test::run_node("io/npm/write_mcap.mjs", (dir / "bag_1.mcap").string() + " lz4") == 0);
  std::ofstream(dir / "metadata.yaml")
      << "rosbag2_bagfile_information:\n  storage_identifier: mcap\n  relative_file_paths: [bag_0.mcap, bag_1.mcap]\n";
  Ros2Bag bag;
  std::string error;
  REQUIRE(bag.open(dir.string(), &error));
  std::int64_t messages = 0;
  REQUIRE(bag.read(
      [&](const Ros2BagMessage& m) {
        CHECK(*m.type == "std_msgs/msg/String");
        CHECK(*m.encoding == "cdr");
        CHECK(m.time_ns == 1000 + messages % 50);
        ++messages;
      },
      &error));
  CHECK(messages == 100);
  CHECK(bag.topics().at("/a").messages == 66);
  CHECK(bag.topics().at("/b").messages == 34);
  fs::remove_all(dir);
}
