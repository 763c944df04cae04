#pragma once
/// @file The live page's WebSocket clients (--http): one sender thread per page reads the ViewFeed from where that page
/// is and sends what is new every period, within the page's byte budget. A page that does not read (a send that
/// blocks past max_send_s or fails) is dropped; the engine only ever appends to the feed, so no page can slow it.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <thread>

#include "loopd/web/http_server.hpp"
#include "loopd/web/view_feed.hpp"

namespace loopd {

/// @brief Limits per page.
struct ViewClientsConfig {
  int max_clients = 4;                         ///< pages at once (more are refused)
  std::int64_t bytes_per_s = 2 * 1024 * 1024;  ///< [bytes/s] sent to one page at most (a new page catches up at this rate)
  int period_ms = 250;                         ///< how often a page is sent what is new
  double max_send_s = 2.0;                     ///< [s] a page whose send takes longer (it does not read) is dropped
};

/// @brief The pages connected to a ViewFeed.
class ViewClients {
 public:
  ViewClients(const ViewFeed& feed, ViewClientsConfig config);
  ~ViewClients();  ///< stops every sender (the server must be stopped first: its callbacks reach this)
  ViewClients(const ViewClients&) = delete;
  ViewClients& operator=(const ViewClients&) = delete;

  /// @brief The WebSocket service to serve (HttpServer::add_websocket).
  WebSocketService service();

  struct Stats {
    std::int64_t connected = 0;   ///< pages now
    std::int64_t served = 0;      ///< pages since start
    std::int64_t dropped = 0;     ///< pages dropped because they did not read
    std::int64_t bytes_sent = 0;  ///< [bytes] to every page, since start
  };
  Stats stats() const;

 private:
  struct Client;
  void run(Client& client);
  void reap();  ///< joins the senders that ended (mutex_ held)

  const ViewFeed& feed_;
  ViewClientsConfig config_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::list<std::unique_ptr<Client>> clients_;
  std::atomic<std::int64_t> connected_{0}, served_{0}, dropped_{0}, bytes_sent_{0};
};

}  // namespace loopd
