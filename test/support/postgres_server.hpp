#pragma once
// A PostgreSQL server of the test's own (scripts/pg-local): data, log and socket in a fresh temp folder, no TCP, a
// password on the socket; stopped and removed with the object. Tests skip (WARN) when the server binaries are missing.
#include <optional>
#include <string>

namespace loopd::test {

class PostgresServer {
 public:
  explicit PostgresServer(std::string password = "loopdtest1");
  ~PostgresServer();
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  /// @brief Initialises and starts the server (database "loopd"); false and reason() when it could not.
  bool start();
  /// @brief Uses the server already running in `dir` (started by scripts/pg-local with this password, e.g. a ctest
  /// fixture) instead of one of its own: false when none runs there. It is neither stopped nor removed at the end.
  bool attach(const std::string& dir);
  /// @brief True when start() failed because the PostgreSQL server binaries are not installed (skip, do not fail).
  bool binaries_missing() const { return binaries_missing_; }
  const std::string& reason() const { return reason_; }
  /// @brief The libpq URI of database "loopd" (with the password).
  std::string uri() const { return uri_with_password(password_); }
  /// @brief The same URI with another password (wrong-password tests).
  std::string uri_with_password(const std::string& password, const std::string& database = "loopd") const;
  /// @brief Creates database `name` (when missing) and returns its URI; empty on failure (see reason()).
  std::string create_database(const std::string& name);
  /// @brief Creates schema `name` in database "loopd" and returns a URI whose search_path is only that schema (a
  /// fresh map without copying a database); empty on failure (see reason()).
  std::string create_schema(const std::string& name);
  /// @brief Runs `sql` on the database `uri` names with psql; false and reason() when it fails.
  bool sql(const std::string& uri, const std::string& sql);
  /// @brief Runs one query with psql and returns its rows unaligned (`|` between fields, a line per row, no header);
  /// nullopt and reason() when it fails.
  std::optional<std::string> query(const std::string& uri, const std::string& sql);
  /// @brief The URI of `database` as another role (e.g. one the test created with fewer rights).
  std::string uri_as(const std::string& user, const std::string& password, const std::string& database = "loopd") const;
  /// @brief The folder that holds the socket (a URI's host).
  const std::string& dir() const { return dir_; }
  /// @brief Stops the server: "fast" (sessions closed cleanly) or "immediate" (as a crash).
  bool stop(const std::string& mode = "fast");
  /// @brief Starts it again after stop(), or stops and starts it.
  bool restart();

 private:
  bool pg_local(const std::string& arguments, std::string* output = nullptr);

  std::string password_, dir_, reason_;
  bool started_ = false, binaries_missing_ = false;
  bool owned_ = true;  ///< started here: stopped and removed with the object
};

}  // namespace loopd::test
