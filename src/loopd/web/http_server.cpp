#include "loopd/web/http_server.hpp"

#include <arpa/inet.h>
#include <civetweb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include <cstring>
#include <mutex>
#include <regex>

namespace loopd {

std::optional<HttpListen> parse_http_listen(const std::string& text, std::string* error) {
  static const std::regex kListen(R"(^(?:([0-9]{1,3})\.([0-9]{1,3})\.([0-9]{1,3})\.([0-9]{1,3}):)?([0-9]{1,5})$)");
  std::smatch m;
  bool ok = std::regex_match(text, m, kListen) && std::stoi(m[5].str()) <= 65535;
  for (int part = 1; ok && m[1].matched && part <= 4; ++part) ok = std::stoi(m[part].str()) <= 255;
  if (!ok) {
    if (error) *error = "'" + text + "' is not PORT or IPV4:PORT (e.g. 8080 or 0.0.0.0:8080)";
    return std::nullopt;
  }
  HttpListen listen;
  if (m[1].matched) listen.address = text.substr(0, text.rfind(':'));
  listen.port = std::stoi(m[5].str());
  return listen;
}

struct HttpServer::Context {
  mg_context* ctx = nullptr;
  std::map<std::string, HttpHandler> routes;
  std::string websocket_path;  ///< "" until add_websocket
  bool loopback = true;        ///< listening on a loopback address: only loopback Host names are served
  int websocket_clients = 0;
  WebSocketService websocket;
  std::mutex mutex;                                                      ///< guards peers, websocket_path and websocket
  std::map<const mg_connection*, std::shared_ptr<WebSocketPeer>> peers;  ///< connections from the handshake to their close
};

bool WebSocketPeer::send_text(const std::string& text) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!open_ || !conn_) return false;
  if (mg_websocket_write(conn_, MG_WEBSOCKET_OPCODE_TEXT, text.data(), text.size()) <= 0) open_ = false;
  return open_;
}

void WebSocketPeer::close(const std::string& reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!open_ || !conn_) return;
  // Close frame: a 2-byte status (1008, policy violation) and the reason, within the 125 bytes a control frame holds.
  std::string payload = "\x03\xf0" + reason.substr(0, 120);
  mg_websocket_write(conn_, MG_WEBSOCKET_OPCODE_CONNECTION_CLOSE, payload.data(), payload.size());
  open_ = false;
}

bool WebSocketPeer::is_open() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return open_;
}

struct WebSocketPeer::ServerSide {
  static void attach(WebSocketPeer& peer, mg_connection* conn, std::string remote) {
    peer.conn_ = conn;
    peer.remote_ = std::move(remote);
  }
  /// The server closed the connection: no call may touch it after this returns.
  static void gone(WebSocketPeer& peer) {
    std::lock_guard<std::mutex> lock(peer.mutex_);  // waits for a send in progress
    peer.open_ = false;
    peer.conn_ = nullptr;
  }
};

namespace {

std::once_flag library_once;

/// The response's headers and, unless `head`, its body; `allow`: an Allow header (a 405).
int send(mg_connection* conn, const HttpResponse& r, bool head, const char* allow = nullptr) {
  mg_response_header_start(conn, r.status);
  if (allow) mg_response_header_add(conn, "Allow", allow, -1);
  mg_response_header_add(conn, "Content-Type", r.content_type.c_str(), -1);
  mg_response_header_add(conn, "Content-Length", std::to_string(r.body.size()).c_str(), -1);
  mg_response_header_add(conn, "Cache-Control", "no-store", -1);
  mg_response_header_add(conn, "X-Content-Type-Options", "nosniff", -1);
  mg_response_header_send(conn);
  if (!head && !r.body.empty()) mg_write(conn, r.body.data(), r.body.size());
  return r.status;
}

int handle(mg_connection* conn, void* data) {
  const auto* routes = static_cast<const std::map<std::string, HttpHandler>*>(data);
  const mg_request_info* info = mg_get_request_info(conn);
  const std::string method = info->request_method ? info->request_method : "";
  const bool head = method == "HEAD";
  if (!head && method != "GET") return send(conn, {405, "text/plain; charset=utf-8", "loopd serves GET and HEAD only\n"}, false, "GET, HEAD");
  const auto route = routes->find(info->local_uri ? info->local_uri : "");
  if (route == routes->end()) return send(conn, {404, "text/plain; charset=utf-8", "not found\n"}, head);
  try {
    return send(conn, route->second(), head);
  } catch (const std::exception& e) {
    return send(conn, {500, "text/plain; charset=utf-8", std::string("error: ") + e.what() + "\n"}, head);
  }
}

int quiet_log(const mg_connection*, const char*) { return 1; }  // civetweb's own error lines stay off loopd's log

/// An answer written whole: civetweb's response-header calls are not ready this early in a request.
int refuse(mg_connection* conn, int status, const char* reason, const std::string& body) {
  const std::string reply = "HTTP/1.1 " + std::to_string(status) + " " + reason +
                            "\r\nContent-Type: text/plain; charset=utf-8\r\nContent-Length: " + std::to_string(body.size()) +
                            "\r\nConnection: close\r\n\r\n" + body;
  mg_write(conn, reply.data(), reply.size());
  return status;
}

/// The host of a Host header ("127.0.0.1:8090" -> "127.0.0.1", "[::1]:80" -> "[::1]").
std::string host_name(const std::string& host) {
  const std::size_t colon = host.rfind(':');
  return colon != std::string::npos && host.find(']', colon) == std::string::npos ? host.substr(0, colon) : host;
}

/// "localhost", "[::1]" or an IPv4 literal in 127.0.0.0/8.
bool is_loopback_name(const std::string& name) {
  if (name == "localhost" || name == "[::1]") return true;
  in_addr a{};
  return inet_pton(AF_INET, name.c_str(), &a) == 1 && (ntohl(a.s_addr) >> 24) == 127;
}

/// Before civetweb handles a request:
/// - on a loopback server, a Host that is not a loopback name is refused (403): a web page the operator visits cannot
///   reach loopd through a DNS name rebound to 127.0.0.1;
/// - a WebSocket handshake from a browser page of another origin (its Origin header is not http://HOST) is refused
///   (403): WebSockets are not bound by the same-origin policy, so any site could otherwise read the feed;
/// - a request to upgrade the connection must be a complete WebSocket handshake to the WebSocket path (RFC 6455 4.2.1:
///   a 24-character base64 Sec-WebSocket-Key and Sec-WebSocket-Version 13), else it is answered 400 here: Debian's
///   civetweb 1.15 crashes (SIGSEGV formatting its own error page) on an upgrade request to any other path, without the
///   key, or with another version, and answers a key that is not base64 with an error body and no status line (both
///   found by fuzz_http_request).
int guard_request(mg_connection* conn) {
  const mg_request_info* info = mg_get_request_info(conn);
  auto* c = static_cast<HttpServer::Context*>(info->user_data);
  std::string websocket_path;
  bool loopback = true;
  if (c) {
    std::lock_guard<std::mutex> lock(c->mutex);
    websocket_path = c->websocket_path;
    loopback = c->loopback;
  }
  const char* host = mg_get_header(conn, "Host");
  if (loopback && host && !is_loopback_name(host_name(host)))
    return refuse(conn, 403, "Forbidden", "loopd listens on loopback: the Host must be 127.0.0.1 or localhost\n");
  if (!mg_get_header(conn, "Upgrade")) return 0;
  const char* origin = mg_get_header(conn, "Origin");
  if (origin && (!host || std::string(origin) != std::string("http://") + host))
    return refuse(conn, 403, "Forbidden", "a WebSocket from a page of another origin\n");
  const char* key = mg_get_header(conn, "Sec-WebSocket-Key");
  const char* version = mg_get_header(conn, "Sec-WebSocket-Version");
  const std::string path = info->local_uri ? info->local_uri : "";
  // RFC 6455 4.1: the key is 16 bytes in base64, 24 characters (civetweb answers another with a bare error body).
  const bool key_ok = key && std::strlen(key) == 24 && std::strspn(key, "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/=") == 24;
  const bool handshake = !websocket_path.empty() && path == websocket_path && key_ok && version && std::strcmp(version, "13") == 0;
  if (handshake) return 0;
  return refuse(conn, 400, "Bad Request", "not a WebSocket handshake loopd accepts (RFC 6455: Sec-WebSocket-Key, Sec-WebSocket-Version 13)\n");
}

using Context = HttpServer::Context;

int websocket_connect(const mg_connection*, void* data) {
  auto* c = static_cast<Context*>(data);
  std::lock_guard<std::mutex> lock(c->mutex);
  return static_cast<int>(c->peers.size()) < c->websocket_clients ? 0 : 1;  // non-zero: refused before the handshake
}

void websocket_ready(mg_connection* conn, void* data) {
  auto* c = static_cast<Context*>(data);
  auto peer = std::make_shared<WebSocketPeer>();
  const mg_request_info* info = mg_get_request_info(conn);
  WebSocketPeer::ServerSide::attach(*peer, conn, std::string(info->remote_addr) + ":" + std::to_string(info->remote_port));
  {
    std::lock_guard<std::mutex> lock(c->mutex);
    c->peers[conn] = peer;
  }
  if (!c->websocket.on_open || !c->websocket.on_open(peer)) peer->close("refused");
}

int websocket_data(mg_connection* conn, int bits, char*, size_t, void* data) {
  auto* c = static_cast<Context*>(data);
  if ((bits & 0x0f) == MG_WEBSOCKET_OPCODE_CONNECTION_CLOSE) return 0;
  std::lock_guard<std::mutex> lock(c->mutex);
  const auto peer = c->peers.find(conn);
  return peer != c->peers.end() && peer->second->is_open() ? 1 : 0;  // what a client sends is read and ignored
}

void websocket_close(const mg_connection* conn, void* data) {
  auto* c = static_cast<Context*>(data);
  std::shared_ptr<WebSocketPeer> peer;
  {
    std::lock_guard<std::mutex> lock(c->mutex);
    const auto found = c->peers.find(conn);
    if (found == c->peers.end()) return;
    peer = found->second;
    c->peers.erase(found);
  }
  WebSocketPeer::ServerSide::gone(*peer);
  if (c->websocket.on_close) c->websocket.on_close(peer);
}

}  // namespace

std::unique_ptr<HttpServer> HttpServer::start(const HttpServerConfig& config, std::map<std::string, HttpHandler> routes, std::string* error) {
  std::call_once(library_once, [] { mg_init_library(0); });
  std::unique_ptr<HttpServer> server(new HttpServer());
  server->context_ = std::make_unique<Context>();
  server->context_->routes = std::move(routes);
  const std::string ports = config.listen.address + ":" + std::to_string(config.listen.port);
  const std::string threads = std::to_string(std::max(1, config.threads));
  const std::string timeout = std::to_string(std::max(100, config.request_timeout_ms));
  server->context_->websocket_clients = std::max(0, config.websocket_clients);
  server->context_->loopback = config.listen.address.rfind("127.", 0) == 0;
  // No document_root: civetweb serves no file. No keep-alive: each scrape is one short connection. A WebSocket client
  // that sends nothing for the timeout is pinged; one that does not read is dropped when a send times out.
  const char* options[] = {"listening_ports",
                           ports.c_str(),
                           "num_threads",
                           threads.c_str(),
                           "request_timeout_ms",
                           timeout.c_str(),
                           "enable_keep_alive",
                           "no",
                           "websocket_timeout_ms",
                           timeout.c_str(),
                           "enable_websocket_ping_pong",
                           "yes",
                           "max_request_size",
                           "16384",
                           nullptr};
  mg_callbacks callbacks;
  std::memset(&callbacks, 0, sizeof callbacks);
  callbacks.log_message = quiet_log;
  callbacks.begin_request = guard_request;
  server->context_->ctx = mg_start(&callbacks, server->context_.get(), options);
  if (!server->context_->ctx) {
    if (error) *error = "cannot listen on " + ports + " (address not on this machine, or the port is in use)";
    return nullptr;
  }
  // One handler for every path ("" and below): unknown paths answer 404 from it, never from a file.
  mg_set_request_handler(server->context_->ctx, "/", handle, &server->context_->routes);
  mg_server_port port{};
  if (mg_get_server_ports(server->context_->ctx, 1, &port) < 1) {
    if (error) *error = "listening on " + ports + " but no port was reported";
    return nullptr;
  }
  server->address_ = config.listen.address;
  server->port_ = port.port;
  return server;
}

void HttpServer::add_websocket(const std::string& path, WebSocketService service) {
  {
    std::lock_guard<std::mutex> lock(context_->mutex);
    context_->websocket = std::move(service);
    context_->websocket_path = path;
  }
  mg_set_websocket_handler(context_->ctx, path.c_str(), websocket_connect, websocket_ready, websocket_data, websocket_close, context_.get());
}

namespace {
/// Opens and closes a connection to the server's own port (0.0.0.0: loopback), without waiting.
void poke(const std::string& address, int port) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK, 0);
  if (fd < 0) return;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = address == "0.0.0.0" ? htonl(INADDR_LOOPBACK) : inet_addr(address.c_str());
  connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  close(fd);
}
}  // namespace

HttpServer::~HttpServer() {
  if (!context_ || !context_->ctx) return;
  // WebSocket clients are told first (a close frame): a browser answers it and its connection ends now, where civetweb
  // would otherwise wait for its read's poll period.
  std::vector<std::shared_ptr<WebSocketPeer>> peers;
  {
    std::lock_guard<std::mutex> lock(context_->mutex);
    for (const auto& [conn, peer] : context_->peers) peers.push_back(peer);
  }
  for (const auto& peer : peers) peer->close("loopd stops");
  // civetweb's listening thread sees the stop only when its poll returns, after up to its poll period (measured: up to
  // 1 s at the end of a replay); a connection to the server's own port ends that poll at once.
  std::atomic<bool> stopped{false};
  std::thread waker([&] {
    for (int i = 0; i < 200 && !stopped.load(); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      poke(address_, port_);
    }
  });
  mg_stop(context_->ctx);
  stopped = true;
  waker.join();
}

std::string HttpServer::url() const { return "http://" + address_ + ":" + std::to_string(port_); }

}  // namespace loopd
