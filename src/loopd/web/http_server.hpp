#pragma once
/// @file A small read-only HTTP server for loopd's endpoints (/metrics, /healthz), on Debian's civetweb: GET and HEAD
/// only, a fixed set of paths, no file served, loopback unless an address is given, a bounded number of threads.
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>

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

/// @brief Settings of the server.
struct HttpServerConfig {
  HttpListen listen;
  int threads = 2;                ///< requests served at once; more connections wait in the kernel's backlog
  int request_timeout_ms = 5000;  ///< a client that sends or reads slower than this is dropped
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

 private:
  HttpServer() = default;
  struct Context;
  std::unique_ptr<Context> context_;
  std::string address_;
  int port_ = 0;
};

}  // namespace loopd
