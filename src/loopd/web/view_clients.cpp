#include "loopd/web/view_clients.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include <pthread.h>

namespace loopd {

struct ViewClients::Client {
  std::shared_ptr<WebSocketPeer> peer;
  std::thread thread;
  bool done = false;  ///< the sender ended (mutex_): join it
};

ViewClients::ViewClients(const ViewFeed& feed, ViewClientsConfig config) : feed_(feed), config_(config) {}

ViewClients::~ViewClients() {
  std::list<std::unique_ptr<Client>> clients;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    clients.swap(clients_);
  }
  wake_.notify_all();
  for (auto& c : clients) {
    c->peer->close("loopd stops");
    if (c->thread.joinable()) c->thread.join();
  }
}

void ViewClients::reap() {
  for (auto it = clients_.begin(); it != clients_.end();) {
    if ((*it)->done) {
      (*it)->thread.join();
      it = clients_.erase(it);
    } else {
      ++it;
    }
  }
}

WebSocketService ViewClients::service() {
  WebSocketService s;
  s.on_open = [this](const std::shared_ptr<WebSocketPeer>& peer) {
    std::lock_guard<std::mutex> lock(mutex_);
    reap();
    if (stopping_ || static_cast<int>(clients_.size()) >= config_.max_clients) return false;
    clients_.push_back(std::make_unique<Client>());
    Client& c = *clients_.back();
    c.peer = peer;
    ++connected_;
    ++served_;
    c.thread = std::thread([this, &c] {
      pthread_setname_np(pthread_self(), "loopd-view");
      run(c);
      --connected_;
      std::lock_guard<std::mutex> lock(mutex_);
      c.done = true;
    });
    return true;
  };
  s.on_close = [this](const std::shared_ptr<WebSocketPeer>&) { wake_.notify_all(); };
  return s;
}

void ViewClients::run(Client& c) {
  using Clock = std::chrono::steady_clock;
  ViewCursor cursor;
  const double rate = static_cast<double>(std::max<std::int64_t>(1024, config_.bytes_per_s));
  double tokens = rate;  // one second of budget at once, at most
  Clock::time_point last = Clock::now();
  bool first = true;
  while (c.peer->is_open()) {
    if (!first) {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(config_.period_ms), [&] { return stopping_ || !c.peer->is_open(); });
      if (stopping_) return;
    }
    first = false;
    const Clock::time_point now = Clock::now();
    tokens = std::min(rate, tokens + rate * std::chrono::duration<double>(now - last).count());
    last = now;
    if (tokens < 4096.0) continue;
    const std::string message = feed_.next_message(&cursor, static_cast<std::size_t>(tokens));
    if (message.empty()) continue;
    const Clock::time_point sent = Clock::now();
    const bool ok = c.peer->send_text(message);
    const double send_s = std::chrono::duration<double>(Clock::now() - sent).count();
    // A send that fails at once: the page closed (a tab closed, a reload). One that blocks past max_send_s, or fails
    // after blocking that long: the page stopped reading; it is dropped.
    if (!ok && send_s < config_.max_send_s) return;
    if (!ok || send_s > config_.max_send_s) {
      ++dropped_;
      std::fprintf(stderr, "loopd: http: page %s dropped: it stopped reading (a send blocked for %.1f s)\n", c.peer->remote().c_str(), send_s);
      c.peer->close("too slow");
      return;
    }
    tokens -= static_cast<double>(message.size());
    bytes_sent_ += static_cast<std::int64_t>(message.size());
  }
}

ViewClients::Stats ViewClients::stats() const { return {connected_.load(), served_.load(), dropped_.load(), bytes_sent_.load()}; }

}  // namespace loopd
