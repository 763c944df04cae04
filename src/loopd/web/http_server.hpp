#pragma once
/// @file A small read-only HTTP server for loopd's endpoints (/metrics, /healthz, the live page and its WebSocket), on
/// Debian's civetweb: GET and HEAD only, a fixed set of paths (no path is ever mapped to a file by its name),
/// loopback unless an address is given, a bounded number of threads and WebSocket clients.
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

struct mg_connection;

namespace loopd {

/// @brief Where to listen: "PORT" (loopback), "ADDRESS:PORT" with an IPv4 address; port 0 picks a free one.
struct HttpListen {
  std::string address = "127.0.0.1";
  int port = 0;
};
/// @brief Parses "PORT" or "IPV4:PORT"; nullopt and `error` (naming the text) when it is neither.
std::optional<HttpListen> parse_http_listen(const std::string& text, std::string* error);

/// @brief What a handler answers.
struct HttpResponse {
  int status = 200;
  std::string content_type = "text/plain; charset=utf-8";
  std::string body;
};
/// @brief Answers a GET of one path. Runs on the server's threads: it must only read state safe to read from them.
using HttpHandler = std::function<HttpResponse()>;

/// @brief One WebSocket client as the service behind it sees it: text frames out; nothing it sends is acted on.
class WebSocketPeer {
 public:
  /// @brief Sends one text frame; false when the client is gone or the send failed (it did not read for the server's
  /// request timeout). One send at a time per peer.
  bool send_text(const std::string& text);
  /// @brief Ends the connection with a close frame carrying `reason`; later sends return false.
  void close(const std::string& reason);
  bool is_open() const;
  /// @brief "ADDRESS:PORT" of the client.
  const std::string& remote() const { return remote_; }

  struct ServerSide;  ///< the server's hold on a peer (http_server.cpp)

 private:
  mg_connection* conn_ = nullptr;
  mutable std::mutex mutex_;
  bool open_ = true;
  std::string remote_;
};

/// @brief A WebSocket endpoint: `on_open` when a client connected (false: refused, closed at once), `on_close` when
/// it is gone (either side closed it, or the server stops). Both run on the server's threads.
struct WebSocketService {
  std::function<bool(const std::shared_ptr<WebSocketPeer>&)> on_open;
  std::function<void(const std::shared_ptr<WebSocketPeer>&)> on_close;
};

/// @brief Settings of the server.
struct HttpServerConfig {
  HttpListen listen;
  int threads = 2;                ///< requests served at once, WebSocket clients included (each holds one)
  int request_timeout_ms = 5000;  ///< a client that sends or reads slower than this is dropped
  int websocket_clients = 0;      ///< WebSocket connections at most (more are refused before the handshake)
};

/// @brief A running server; stops when destroyed.
class HttpServer {
 public:
  /// @brief Starts serving `routes` (exact paths, e.g. "/metrics"); null and `error` when it cannot (port in use, bad
  /// address). Any other path is 404; a method other than GET or HEAD is 405.
  static std::unique_ptr<HttpServer> start(const HttpServerConfig& config, std::map<std::string, HttpHandler> routes, std::string* error);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;
  /// @brief The port it listens on (the one picked when asked for 0).
  int port() const { return port_; }
  /// @brief "http://ADDRESS:PORT".
  std::string url() const;
  /// @brief Serves WebSocket connections at `path` (at most config.websocket_clients at once) with `service`.
  void add_websocket(const std::string& path, WebSocketService service);

  struct Context;  ///< the implementation's (civetweb's callbacks reach it)

 private:
  HttpServer() = default;
  std::unique_ptr<Context> context_;
  std::string address_;
  int port_ = 0;
};

}  // namespace loopd
