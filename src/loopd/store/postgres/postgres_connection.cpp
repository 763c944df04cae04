#include "loopd/store/postgres/postgres_connection.hpp"

#include <pqxx/pqxx>

#include <algorithm>

namespace loopd::postgres {

using Code = StoreStatus::Code;

Code code_of_sqlstate(const std::string& s) {
  if (s.rfind("08", 0) == 0 || s == "57P01" || s == "57P02" || s == "57P03") return Code::kUnavailable;  // connection, shutdown
  if (s.rfind("28", 0) == 0 || s == "3D000") return Code::kInvalid;                                      // credentials, no database
  if (s == "40001" || s == "40P01" || s == "55P03") return Code::kBusy;                                  // serialization, deadlock, lock
  if (s.rfind("53", 0) == 0 || s.rfind("58", 0) == 0) return Code::kIo;                                  // resources, system
  if (s == "XX001" || s == "XX002") return Code::kCorrupt;                                               // data or index corrupted
  return Code::kInvalid;                                                                                 // constraints, syntax
}

std::string one_line(std::string message) {
  for (char& c : message)
    if (c == '\n' || c == '\t') c = ' ';
  while (!message.empty() && message.back() == ' ') message.pop_back();
  std::string out;
  for (char c : message)
    if (c != ' ' || out.empty() || out.back() != ' ') out += c;
  return out;
}

struct Connection::Link {
  explicit Link(const std::string& uri) : connection(uri) {}
  pqxx::connection connection;
};

std::string with_connection_defaults(const std::string& uri) {
  static const char* const kDefaults[][2] = {
      {"connect_timeout", "5"}, {"keepalives_idle", "10"}, {"keepalives_interval", "5"}, {"keepalives_count", "3"}, {"tcp_user_timeout", "15000"}};
  std::string out = uri;
  for (const auto& [name, value] : kDefaults) {
    const std::string key = std::string(name) + "=";
    const auto query = out.find('?');
    const bool present = query != std::string::npos && (out.find("?" + key) != std::string::npos || out.find("&" + key) != std::string::npos);
    if (!present) out += (query == std::string::npos ? "?" : "&") + key + value;
  }
  return out;
}

Connection::Connection(std::string uri, std::string display_uri, bool read_only, int lock_timeout_ms)
    : uri_(with_connection_defaults(uri)), display_(std::move(display_uri)), read_only_(read_only), lock_timeout_ms_(lock_timeout_ms) {}

Connection::~Connection() {
  tx_.reset();  // aborts an open transaction (its destructor never throws)
  conn_.reset();
}

StoreStatus Connection::connect() {
  next_try_ = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  try {
    conn_.reset();
    conn_ = std::make_unique<Link>(uri_);
    // Never reconnect behind our back: a new connection has lost the session's locks and any open transaction.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
    conn_->connection.inhibit_reactivation(true);
#pragma GCC diagnostic pop
    pqxx::nontransaction session(conn_->connection);
    session.exec("SET client_min_messages = warning");  // no NOTICE lines on stderr
    if (read_only_) session.exec("SET default_transaction_read_only = on");
    // MapStoreConfig::busy_timeout_ms (PostgreSQL reads 0 as no limit; SQLite as none at all)
    session.exec("SET lock_timeout = " + std::to_string(std::max(1, lock_timeout_ms_)));
    return {};
  } catch (const pqxx::broken_connection& e) {
    conn_.reset();
    const std::string why = one_line(e.what());
    // libpq reports refused credentials and a missing database or role through the same exception as a dead socket.
    const bool refused = why.find("authentication failed") != std::string::npos || why.find("does not exist") != std::string::npos;
    return {refused ? Code::kInvalid : Code::kUnavailable, "map " + display_ + ": cannot connect: " + why};
  } catch (const std::exception& e) {
    conn_.reset();
    return {Code::kInvalid, "map " + display_ + ": cannot connect: " + one_line(e.what())};
  }
}

bool Connection::usable() {
  if (conn_ && conn_->connection.is_open()) return true;
  if (tx_) return false;  // a transaction died with the connection: rollback() first
  if (std::chrono::steady_clock::now() < next_try_) return false;
  return connect().ok();
}

void Connection::drop() {
  try {
    conn_.reset();
  } catch (const std::exception&) {}
}

StoreStatus Connection::unavailable(const std::string& operation, const std::string& why) const {
  return {Code::kUnavailable, "map " + display_ + ": " + operation + ": the server is unavailable (" + why + ")"};
}

StoreStatus Connection::failed(const std::string& operation, const std::exception& e) {
  const std::string why = one_line(e.what());
  Code code = Code::kInvalid;
  if (dynamic_cast<const pqxx::broken_connection*>(&e) || dynamic_cast<const pqxx::in_doubt_error*>(&e)) {
    code = Code::kUnavailable;
  } else if (const auto* sql = dynamic_cast<const pqxx::sql_error*>(&e)) {
    code = code_of_sqlstate(sql->sqlstate());
  }
  // A server that dies mid-statement surfaces as an sql_error without SQLSTATE ("server closed the connection
  // unexpectedly"); libpq's own state says the connection is gone.
  if (conn_ && !conn_->connection.is_open()) code = Code::kUnavailable;
  for (const char* gone : {"server closed the connection", "no connection to the server", "terminating connection"})
    if (why.find(gone) != std::string::npos) code = Code::kUnavailable;
  if (code != Code::kUnavailable) {
    // The server has aborted the open transaction: COMMIT would roll it back and report success.
    if (tx_ && tx_failed_.empty()) tx_failed_ = operation + ": " + why;
    return {code, "map " + display_ + ": " + operation + ": " + why};
  }
  if (tx_)
    tx_lost_ = true;  // the transaction is gone with the connection: kUnavailable until rollback()/commit()
  else
    drop();
  return unavailable(operation, why);
}

StoreStatus Connection::run(const std::string& operation, const std::function<void(pqxx::transaction_base&)>& work) {
  if (tx_lost_) return unavailable(operation, "the connection was lost inside the transaction");
  if (!tx_failed_.empty())
    return {Code::kInvalid, "map " + display_ + ": " + operation + ": the transaction failed earlier (" + tx_failed_ + "): roll back"};
  if (!usable()) return unavailable(operation, "not connected");
  try {
    if (tx_) {
      work(*tx_);
      return {};
    }
    pqxx::work t(conn_->connection);
    work(t);
    t.commit();
    return {};
  } catch (const std::exception& e) {
    return failed(operation, e);
  }
}

StoreStatus Connection::begin() {
  if (tx_) return {Code::kInvalid, "map " + display_ + ": begin: a transaction is already open"};
  if (!usable()) return unavailable("begin", "not connected");
  try {
    tx_ = std::make_unique<pqxx::work>(conn_->connection);
    tx_lost_ = false;
    tx_failed_.clear();
    return {};
  } catch (const std::exception& e) {
    return failed("begin", e);
  }
}

StoreStatus Connection::commit() {
  if (!tx_) return {Code::kInvalid, "map " + display_ + ": commit: no open transaction"};
  if (tx_lost_) {
    rollback();
    return unavailable("commit", "the connection was lost inside the transaction");
  }
  if (!tx_failed_.empty()) {
    const std::string why = tx_failed_;
    rollback();
    return {Code::kInvalid, "map " + display_ + ": commit: rolled back, a statement of the transaction failed (" + why + ")"};
  }
  try {
    tx_->commit();
    tx_.reset();
    return {};
  } catch (const std::exception& e) {
    tx_.reset();
    StoreStatus s = failed("commit", e);
    return s;
  }
}

StoreStatus Connection::rollback() {
  const bool lost = tx_lost_;
  tx_lost_ = false;
  tx_failed_.clear();
  if (!tx_) return {};
  try {
    if (!lost) tx_->abort();
  } catch (const std::exception&) {}
  tx_.reset();
  if (lost) drop();
  return {};
}

}  // namespace loopd::postgres
