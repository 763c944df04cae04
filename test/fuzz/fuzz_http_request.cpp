// loopd's HTTP endpoint (src/loopd/web: HttpServer's routes and WebSocket, ViewClients) as a browser or an attacker
// reaches it: each input is sent as the bytes of one TCP connection to a real server on a loopback port (a request,
// a WebSocket handshake and frames, anything), then the reply is read. The server must answer each connection or close
// it, never serve a file outside its table, and still answer a plain request afterwards.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <memory>

#include "fuzz_support.hpp"
#include "loopd/web/http_server.hpp"
#include "loopd/web/page_files.hpp"
#include "loopd/web/view_clients.hpp"

namespace {

using namespace loopd;

struct Server {
  ViewFeed feed;
  ViewClients clients{feed, ViewClientsConfig{2, 1 << 20, 10, 0.5}};
  std::unique_ptr<HttpServer> http;
  Server() {
    feed.add_keyframe({0, 0}, 1, Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity(), nullptr);
    std::map<std::string, HttpHandler> routes = page_routes(find_page_dir());
    routes["/healthz"] = [] { return HttpResponse{200, "text/plain; charset=utf-8", "ok\n"}; };
    HttpServerConfig config;
    config.websocket_clients = 2;
    config.threads = 4;
    config.request_timeout_ms = 500;
    std::string error;
    http = HttpServer::start(config, routes, &error);
    fuzz::check(http != nullptr, "the server starts on a free loopback port");
    http->add_websocket("/ws", clients.service());
  }
};

/// Sends `bytes` on a new connection, ends the sending side and reads what comes back (at most ~2 s).
std::string exchange(int port, const std::uint8_t* bytes, std::size_t size) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  timeval timeout{2, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof timeout);
  std::string reply;
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0) {
    for (std::size_t sent = 0; sent < size;) {
      const ssize_t n = send(fd, bytes + sent, size - sent, MSG_NOSIGNAL);
      if (n <= 0) break;
      sent += static_cast<std::size_t>(n);
    }
    shutdown(fd, SHUT_WR);
    char buffer[65536];
    for (ssize_t n; reply.size() < (8u << 20) && (n = recv(fd, buffer, sizeof buffer, 0)) > 0;) reply.append(buffer, static_cast<std::size_t>(n));
  }
  close(fd);
  return reply;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Server server;
  static int runs = 0;
  const std::string reply = exchange(server.http->port(), data, size);
  // civetweb echoes the request's protocol token in its status line (a "HTTP/1H1" request gets "HTTP/1H1 400").
  fuzz::check(reply.empty() || reply.rfind("HTTP/", 0) == 0, "a reply is an HTTP response");
  // /etc/passwd's first line in a reply is a file served from outside the table, unless the request carried it (civetweb
  // echoes parts of a bad request line).
  const bool echoed = fuzz::as_string(data, size).find("root:x:0:0") != std::string::npos;
  fuzz::check(echoed || reply.find("root:x:0:0") == std::string::npos, "no file outside the page's table is served");
  if (++runs % 200 == 0) {
    static const std::string kPlain = "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
    const std::string ok = exchange(server.http->port(), reinterpret_cast<const std::uint8_t*>(kPlain.data()), kPlain.size());
    fuzz::check(ok.rfind("HTTP/1.1 200", 0) == 0, "the server still answers a plain request");
  }
  return 0;
}
