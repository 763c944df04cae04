#pragma once
/// @file One libpqxx connection as the PostgreSQL map uses it: statements run in the caller's open transaction or in
/// one of their own; a lost connection is kUnavailable (never an exception) and is made again at most once a second.
/// No libpqxx header here: its classes are only named.
#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include "loopd/store/map_store.hpp"

namespace pqxx {
class dbtransaction;
class transaction_base;
}  // namespace pqxx

namespace loopd::postgres {

class Connection {
 public:
  /// @param uri the libpq URI (with the password); display_uri the same with the password masked (messages);
  /// read_only every transaction read-only; lock_timeout_ms how long a statement waits for another's lock (kBusy).
  Connection(std::string uri, std::string display_uri, bool read_only, int lock_timeout_ms);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  /// @brief Connects now (at open); the status says why not.
  StoreStatus connect();
  /// @brief Runs `work` in the open transaction (begin()) or in its own, committed; errors become a StoreStatus.
  StoreStatus run(const std::string& operation, const std::function<void(pqxx::transaction_base&)>& work);
  StoreStatus begin();
  StoreStatus commit();
  StoreStatus rollback();
  const std::string& display_uri() const { return display_; }

 private:
  bool usable();
  void drop();
  StoreStatus failed(const std::string& operation, const std::exception& e);
  StoreStatus unavailable(const std::string& operation, const std::string& why) const;

  std::string uri_, display_;
  bool read_only_;
  int lock_timeout_ms_;
  struct Link;  ///< the pqxx::connection (its base class has no virtual destructor: held by value in here)
  std::unique_ptr<Link> conn_;
  std::unique_ptr<pqxx::dbtransaction> tx_;
  bool tx_lost_ = false;   ///< the open transaction died with the connection: its writes fail until rollback/commit
  std::string tx_failed_;  ///< why a statement of the open transaction failed (the server aborted it): commit refuses
  std::chrono::steady_clock::time_point next_try_{};
};

/// @brief The StoreStatus code for a server error class (SQLSTATE).
StoreStatus::Code code_of_sqlstate(const std::string& sqlstate);

/// @brief `uri` with loopd's connection defaults where it sets none: connect_timeout (an unreachable TCP server is
/// kUnavailable in seconds, not minutes) and TCP keepalives / tcp_user_timeout (a silently dropped link too).
std::string with_connection_defaults(const std::string& uri);

/// @brief A libpqxx message on one line (no trailing newline; libpq's "FATAL:  " prefix kept).
std::string one_line(std::string message);

}  // namespace loopd::postgres
