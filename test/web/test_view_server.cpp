// The live page's server side (src/loopd/web: HttpServer's WebSocket, ViewClients, the page's files): a real server on
// a loopback port, real WebSocket clients (civetweb's client, and a raw socket that stops reading).
#include <catch2/catch.hpp>

#include <arpa/inet.h>
#include <chrono>
#include <civetweb.h>
#include <mutex>
#include <netinet/in.h>
#include <nlohmann/json.hpp>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>

#include "loopd/web/http_server.hpp"
#include "loopd/web/page_files.hpp"
#include "loopd/web/view_clients.hpp"
#include "support/http_client.hpp"

using namespace loopd;
using Json = nlohmann::json;
using loopd::test::http_request;

namespace {

/// A page as a browser holds it: civetweb's WebSocket client, every text frame kept.
class PageClient {
 public:
  explicit PageClient(int port) {
    char error[256] = {0};
    conn_ = mg_connect_websocket_client("127.0.0.1", port, 0, error, sizeof error, "/ws", nullptr, on_data, on_close, this);
    error_ = error;
  }
  ~PageClient() {
    if (conn_) mg_close_connection(conn_);
  }
  bool connected() const { return conn_ != nullptr; }
  const std::string& error() const { return error_; }
  std::vector<std::string> messages() {
    std::lock_guard<std::mutex> lock(mutex_);
    return messages_;
  }
  bool closed() {
    std::lock_guard<std::mutex> lock(mutex_);
    return closed_;
  }
  /// Waits until `done` holds for the messages so far (at most `seconds`).
  template <typename Pred>
  bool wait(Pred done, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      if (done(messages())) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return done(messages());
  }

 private:
  static int on_data(mg_connection*, int bits, char* data, size_t size, void* self) {
    auto* c = static_cast<PageClient*>(self);
    if ((bits & 0x0f) == MG_WEBSOCKET_OPCODE_TEXT) {
      std::lock_guard<std::mutex> lock(c->mutex_);
      c->messages_.emplace_back(data, size);
    }
    return 1;
  }
  static void on_close(const mg_connection*, void* self) {
    auto* c = static_cast<PageClient*>(self);
    std::lock_guard<std::mutex> lock(c->mutex_);
    c->closed_ = true;
  }
  mg_connection* conn_ = nullptr;
  std::string error_;
  std::mutex mutex_;
  std::vector<std::string> messages_;
  bool closed_ = false;
};

/// A page that completes the handshake and then never reads (a stalled browser tab, a client on a dead link).
int stalled_client(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  int small = 4096;
  setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return -1;
  const std::string handshake =
      "GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
  if (send(fd, handshake.data(), handshake.size(), 0) != static_cast<ssize_t>(handshake.size())) return -1;
  std::string head;
  char c;
  while (head.find("\r\n\r\n") == std::string::npos && recv(fd, &c, 1, 0) == 1) head += c;
  return head.rfind("HTTP/1.1 101", 0) == 0 ? fd : -1;
}

std::size_t decisions_in(const std::vector<std::string>& messages) {
  std::size_t n = 0;
  for (const std::string& m : messages) n += Json::parse(m).value("decisions", Json::array()).size();
  return n;
}

/// The event id of the last decision in a message (0: none).
std::int64_t last_decision(const std::string& message) {
  const Json m = Json::parse(message);
  return m.contains("decisions") && !m["decisions"].empty() ? m["decisions"].back()["id"].get<std::int64_t>() : 0;
}

LoopDecision rejected(std::int64_t id) {
  LoopDecision d;
  d.event_id = id;
  d.query = {0, id};
  d.status = LoopStatus::kRejected;
  d.stage = "descriptor";
  d.reason = std::string(200, 'r');  // ~0.5 KB a decision
  return d;
}

}  // namespace

TEST_CASE("view server: a page gets the feed over the WebSocket as it grows - pages beyond the bound are refused") {
  ViewFeed feed;
  feed.set_source("test");
  ViewClientsConfig clients_config;
  clients_config.max_clients = 1;
  clients_config.period_ms = 50;
  ViewClients clients(feed, clients_config);
  HttpServerConfig config;
  config.websocket_clients = 1;
  config.threads = 3;
  std::string error;
  auto server = HttpServer::start(config, page_routes(find_page_dir()), &error);
  REQUIRE(server);
  server->add_websocket("/ws", clients.service());

  feed.add_keyframe({0, 0}, 1000000, Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity(), nullptr);
  PageClient page(server->port());
  INFO(page.error());
  REQUIRE(page.connected());
  REQUIRE(page.wait([](const std::vector<std::string>& m) { return !m.empty(); }, 5.0));
  const Json hello = Json::parse(page.messages().front());
  CHECK(hello["type"] == "hello");
  CHECK(hello["source"] == "test");
  CHECK(hello["keyframes"].size() == 1);

  for (int i = 1; i <= 30; ++i) feed.add_decision(rejected(i));
  CHECK(page.wait([](const std::vector<std::string>& m) { return decisions_in(m) == 30; }, 5.0));

  PageClient second(server->port());  // one page at most: refused
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  CHECK((!second.connected() || second.closed() || second.messages().empty()));
  CHECK(clients.stats().connected == 1);
  CHECK(clients.stats().served == 1);
  CHECK(clients.stats().bytes_sent > 30 * 200);

  // The page's files from the fixed table; no other path reaches a file (civetweb removes dot segments first, as RFC
  // 3986 says: "/lib/../view.js" is "/view.js", still in the table).
  if (!find_page_dir().empty()) {
    const auto index = http_request(server->port(), "GET", "/");
    CHECK(index.status == 200);
    CHECK(index.body.find("/view.js") != std::string::npos);
    CHECK(http_request(server->port(), "GET", "/view.js").status == 200);
  }
  for (const char* path : {"/index.html/../../../../etc/passwd", "/../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/lib/three.min.js/..",
                           "/page/index.html", "//etc/passwd"}) {
    INFO(path);
    const auto r = http_request(server->port(), "GET", path);
    CHECK(r.status == 404);
    CHECK(r.body.find("root:") == std::string::npos);
  }
  CHECK(http_request(server->port(), "POST", "/ws").status == 405);

  // Upgrade requests that are not a complete handshake to /ws are answered 400 by loopd (Debian's civetweb 1.15 crashes
  // on each of them: found by fuzz_http_request), and the server answers on.
  const std::string upgrade = "Host: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n";
  const std::string key = "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n";
  for (const std::string& request :
       {"GET /ws HTTP/1.1\r\n" + upgrade + "Sec-WebSocket-Version: 13\r\n\r\n",                                                  // no key
        "GET /ws HTTP/1.1\r\n" + upgrade + key + "\r\n",                                                                         // no version
        "GET /ws HTTP/1.1\r\n" + upgrade + key + "Sec-WebSocket-Version: 8\r\n\r\n",                                             // another version
        "GET /ws HTTP/1.1\r\n" + upgrade + "Sec-WebSocket-Key: fgolIHNX\x89\x89ub52jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",  // key not base64
        "GET /metrics HTTP/1.1\r\n" + upgrade + key + "Sec-WebSocket-Version: 13\r\n\r\n",                                       // not /ws
        std::string("GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: h2c\r\nConnection: Upgrade\r\n\r\n")}) {
    INFO(request);
    CHECK(loopd::test::http_exchange(server->port(), request).status == 400);
  }
  CHECK(http_request(server->port(), "GET", "/view.css").status == (find_page_dir().empty() ? 404 : 200));

  // Served on loopback, loopd answers loopback Host names only (a DNS name rebound to 127.0.0.1 by a web page gets 403),
  // and a WebSocket only to a page of its own origin (any site could otherwise open ws://127.0.0.1:PORT/ws).
  const auto get_with = [&](const std::string& headers) {
    return loopd::test::http_exchange(server->port(), "GET /healthz-or-404 HTTP/1.1\r\n" + headers + "Connection: close\r\n\r\n").status;
  };
  CHECK(get_with("Host: evil.example\r\n") == 403);
  CHECK(get_with("Host: 127.evil.example:80\r\n") == 403);
  CHECK(get_with("Host: localhost:1234\r\n") == 404);  // served: no such path
  CHECK(get_with("Host: 127.0.0.2\r\n") == 404);
  CHECK(get_with("") == 404);  // HTTP/1.0-style, no Host
  const std::string host = "127.0.0.1:" + std::to_string(server->port());
  const std::string handshake =
      "GET /ws HTTP/1.1\r\nHost: " + host + "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n" + key + "Sec-WebSocket-Version: 13\r\n";
  CHECK(loopd::test::http_exchange(server->port(), handshake + "Origin: http://evil.example\r\n\r\n").status == 403);
  CHECK(clients.stats().served == 1);
}

TEST_CASE("view server: a page that stops reading is dropped - the other page and the feed's writer go on") {
  ViewFeed feed;
  ViewClientsConfig clients_config;
  clients_config.max_clients = 2;
  clients_config.period_ms = 20;
  clients_config.bytes_per_s = 256 * 1024 * 1024;  // no rate limit in the way: the socket's buffers fill
  clients_config.max_send_s = 0.5;
  ViewClients clients(feed, clients_config);
  HttpServerConfig config;
  config.websocket_clients = 2;
  config.threads = 4;
  config.request_timeout_ms = 1000;  // a send blocked this long fails
  std::string error;
  auto server = HttpServer::start(config, {}, &error);
  REQUIRE(server);
  server->add_websocket("/ws", clients.service());

  const int stalled = stalled_client(server->port());
  REQUIRE(stalled >= 0);
  PageClient page(server->port());
  REQUIRE(page.connected());
  // ~30 MB of decisions, more than the socket buffers between the server and the stalled page hold.
  for (int i = 1; i <= 60000; ++i) feed.add_decision(rejected(i));
  const auto dropped = [&] { return clients.stats().dropped == 1; };
  for (int i = 0; i < 300 && !dropped(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  CHECK(dropped());
  // The other page gets everything to the newest decision (the feed keeps the newest 20,000 rejected ones).
  CHECK(page.wait([](const std::vector<std::string>& m) { return !m.empty() && last_decision(m.back()) == 60000; }, 30.0));
  CHECK(decisions_in(page.messages()) >= 20000);
  CHECK_FALSE(page.closed());
  close(stalled);
}
