#include "loopd/io/rosbag2_sqlite.hpp"

#include <sqlite3.h>

namespace loopd {

struct Rosbag2SqliteReader::Db {
  sqlite3* handle = nullptr;
  ~Db() {
    if (handle) sqlite3_close(handle);
  }
};

namespace {

/// A prepared statement, finalized when it goes.
struct Statement {
  sqlite3_stmt* s = nullptr;
  ~Statement() {
    if (s) sqlite3_finalize(s);
  }
};

std::string text_of(sqlite3_stmt* s, int column) {
  const unsigned char* t = sqlite3_column_text(s, column);
  return t ? reinterpret_cast<const char*>(t) : "";
}

}  // namespace

Rosbag2SqliteReader::Rosbag2SqliteReader() = default;
Rosbag2SqliteReader::~Rosbag2SqliteReader() = default;

bool Rosbag2SqliteReader::open(const std::string& path, std::string* error) {
  path_ = path;
  db_ = std::make_unique<Db>();
  const auto fail = [&](const std::string& why) {
    if (error) *error = path + ": " + why;
    db_.reset();
    return false;
  };
  if (sqlite3_open_v2(path.c_str(), &db_->handle, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK)
    return fail(std::string("cannot be opened (") + sqlite3_errmsg(db_->handle) + ")");
  Statement topics;
  if (sqlite3_prepare_v2(db_->handle, "SELECT id, name, type, serialization_format FROM topics", -1, &topics.s, nullptr) != SQLITE_OK)
    return fail("not a rosbag2 SQLite file (no topics table: " + std::string(sqlite3_errmsg(db_->handle)) + ")");
  int rc = SQLITE_ROW;
  while ((rc = sqlite3_step(topics.s)) == SQLITE_ROW) {
    Rosbag2Topic t;
    t.id = sqlite3_column_int64(topics.s, 0);
    t.name = text_of(topics.s, 1);
    t.type = text_of(topics.s, 2);
    t.serialization_format = text_of(topics.s, 3);
    topics_[t.id] = std::move(t);
  }
  if (rc != SQLITE_DONE) return fail(std::string("its topics cannot be read (") + sqlite3_errmsg(db_->handle) + ")");
  return true;
}

bool Rosbag2SqliteReader::read(const MessageVisitor& visit, std::string* error) {
  if (!db_) {
    if (error) *error = path_ + ": not open";
    return false;
  }
  Statement messages;
  if (sqlite3_prepare_v2(db_->handle, "SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp, id", -1, &messages.s, nullptr) !=
      SQLITE_OK) {
    if (error) *error = path_ + ": not a rosbag2 SQLite file (no messages table: " + sqlite3_errmsg(db_->handle) + ")";
    return false;
  }
  int rc = SQLITE_ROW;
  while ((rc = sqlite3_step(messages.s)) == SQLITE_ROW) {
    const auto topic = topics_.find(sqlite3_column_int64(messages.s, 0));
    if (topic == topics_.end()) {
      ++orphan_messages_;
      continue;
    }
    const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(messages.s, 2));
    const int size = sqlite3_column_bytes(messages.s, 2);
    visit(topic->second, sqlite3_column_int64(messages.s, 1), data, data ? static_cast<std::size_t>(size) : 0);
  }
  if (rc != SQLITE_DONE) {
    if (error) *error = path_ + ": its messages cannot be read (" + sqlite3_errmsg(db_->handle) + ")";
    return false;
  }
  return true;
}

}  // namespace loopd
