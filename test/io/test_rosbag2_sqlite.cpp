// rosbag2's SQLite storage (src/loopd/io/rosbag2_sqlite): a .db3 file with rosbag2's two tables, made with SQLite
// here, read in time order and never changed; other files refused with the file named.
#include <catch2/catch.hpp>

#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "loopd/io/rosbag2_sqlite.hpp"

using namespace loopd;

namespace {

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("loopd_rosbag2_" + std::to_string(getpid()) + "_" + name)).string();
}

/// rosbag2's schema (topics, messages) with three topics' messages written out of time order, and one row of a topic
/// the topics table does not hold.
void write_bag(const std::string& path) {
  std::filesystem::remove(path);
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(path.c_str(), &db) == SQLITE_OK);
  const char* sql =
      "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, serialization_format TEXT NOT NULL,"
      " offered_qos_profiles TEXT NOT NULL);"
      "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
      "INSERT INTO topics VALUES (1, '/points', 'sensor_msgs/msg/PointCloud2', 'cdr', ''), (2, '/odom', 'nav_msgs/msg/Odometry', 'cdr', ''),"
      " (3, '/tf', 'tf2_msgs/msg/TFMessage', 'cdr', '');"
      "INSERT INTO messages(topic_id, timestamp, data) VALUES (2, 2000, x'0201'), (1, 1000, x'01'), (3, 3000, x''), (9, 1500, x'09'),"
      " (2, 1000, x'0202');";
  REQUIRE(sqlite3_exec(db, sql, nullptr, nullptr, nullptr) == SQLITE_OK);
  sqlite3_close(db);
}

}  // namespace

TEST_CASE("rosbag2 SQLite: topics and messages in time order, rows of an unknown topic counted, the file unchanged") {
  const std::string path = temp_path("bag.db3");
  write_bag(path);
  const auto before = std::filesystem::last_write_time(path);
  Rosbag2SqliteReader reader;
  std::string error;
  REQUIRE(reader.open(path, &error));
  REQUIRE(reader.topics().size() == 3);
  CHECK(reader.topics().at(1).type == "sensor_msgs/msg/PointCloud2");
  CHECK(reader.topics().at(2).serialization_format == "cdr");
  std::vector<std::tuple<std::string, std::int64_t, std::string>> seen;
  REQUIRE(reader.read([&](const Rosbag2Topic& t, std::int64_t ns, const std::uint8_t* data,
                          std::size_t size) { seen.emplace_back(t.name, ns, std::string(reinterpret_cast<const char*>(data), size)); },
                      &error));
  REQUIRE(seen.size() == 4);
  CHECK(seen[0] == std::make_tuple(std::string("/points"), std::int64_t{1000}, std::string("\x01")));
  CHECK(seen[1] == std::make_tuple(std::string("/odom"), std::int64_t{1000}, std::string("\x02\x02")));  // same time: by row id
  CHECK(std::get<1>(seen[2]) == 2000);
  CHECK(seen[3] == std::make_tuple(std::string("/tf"), std::int64_t{3000}, std::string()));
  CHECK(reader.orphan_messages() == 1);
  CHECK(std::filesystem::last_write_time(path) == before);
  CHECK_FALSE(std::filesystem::exists(path + "-journal"));
  std::filesystem::remove(path);
}

TEST_CASE("rosbag2 SQLite: a file that is no SQLite database, and a database without rosbag2's tables, are refused with the file named") {
  const std::string text = temp_path("text.db3");
  std::ofstream(text) << "not a database at all, just text that is long enough to have a header";
  Rosbag2SqliteReader a;
  std::string error;
  CHECK_FALSE(a.open(text, &error));
  CHECK(error.find(text) == 0);
  std::filesystem::remove(text);

  const std::string other = temp_path("other.db3");
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(other.c_str(), &db) == SQLITE_OK);
  REQUIRE(sqlite3_exec(db, "CREATE TABLE keyframes(id INTEGER)", nullptr, nullptr, nullptr) == SQLITE_OK);
  sqlite3_close(db);
  Rosbag2SqliteReader b;
  CHECK_FALSE(b.open(other, &error));
  CHECK(error.find("not a rosbag2 SQLite file") != std::string::npos);
  std::filesystem::remove(other);

  Rosbag2SqliteReader c;
  CHECK_FALSE(c.open(temp_path("missing.db3"), &error));
  CHECK(error.find("cannot be opened") != std::string::npos);
}
