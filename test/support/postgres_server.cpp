#include "support/postgres_server.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <system_error>

#include "support/run_command.hpp"

namespace loopd::test {
namespace {
/// A text as one single-quoted shell word.
std::string shell_quoted(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

constexpr int kBinariesMissing = 3;  // scripts/pg-local's exit code when the server binaries are not installed

std::string pg_local_script() { return std::string(LOOPD_SOURCE_DIR) + "/scripts/pg-local"; }

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

}  // namespace

PostgresServer::PostgresServer(std::string password) : password_(std::move(password)) {}

PostgresServer::~PostgresServer() {
  if (!owned_) return;
  if (started_) pg_local("stop " + dir_ + " --mode immediate");
  if (!dir_.empty()) {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
}

bool PostgresServer::pg_local(const std::string& arguments, std::string* output) {
  int rc = -1;
  const std::string out = run_command(pg_local_script() + " " + arguments, &rc);
  if (output) *output = trimmed(out);
  if (rc == 0) return true;
  binaries_missing_ = rc == kBinariesMissing;
  reason_ = "scripts/pg-local " + arguments + " exited with " + std::to_string(rc) + ": " + trimmed(out);
  return false;
}

bool PostgresServer::start() {
  if (started_) return true;
  // A short path: the socket's path must fit in 107 bytes.
  std::string pattern = "/tmp/loopd_pg_XXXXXX";
  if (!::mkdtemp(pattern.data())) {
    reason_ = "cannot make a temp folder under /tmp";
    return false;
  }
  dir_ = pattern;
  std::string uri;
  started_ = pg_local("start " + dir_ + " --password " + password_, &uri);
  return started_;
}

bool PostgresServer::attach(const std::string& dir) {
  if (started_ || !pg_local("status " + dir)) return false;
  dir_ = dir;
  owned_ = false;
  started_ = true;
  return true;
}

std::string PostgresServer::uri_with_password(const std::string& password, const std::string& database) const {
  return uri_as("loopd", password, database);
}

std::string PostgresServer::uri_as(const std::string& user, const std::string& password, const std::string& database) const {
  return "postgresql://" + user + ":" + password + "@/" + database + "?host=" + dir_;
}

std::string PostgresServer::create_database(const std::string& name) {
  // pg-local start on a running server only creates the database.
  if (!pg_local("start " + dir_ + " --password " + password_ + " --database " + name)) return "";
  return uri_with_password(password_, name);
}

std::string PostgresServer::create_schema(const std::string& name) {
  if (!sql(uri(), "CREATE SCHEMA " + name)) return "";
  return uri() + "&options=-csearch_path%3D" + name;
}

bool PostgresServer::sql(const std::string& uri, const std::string& sql) { return pg_local("psql '" + uri + "' -c " + shell_quoted(sql)); }

std::optional<std::string> PostgresServer::query(const std::string& uri, const std::string& sql) {
  std::string rows;
  if (!pg_local("psql '" + uri + "' -t -A -c " + shell_quoted(sql), &rows)) return std::nullopt;
  return rows;
}

bool PostgresServer::stop(const std::string& mode) { return pg_local("stop " + dir_ + " --mode " + mode); }

bool PostgresServer::restart() { return pg_local("restart " + dir_); }

}  // namespace loopd::test
