#include "loopd/web/http_server.hpp"

#include <civetweb.h>

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

}  // namespace

std::unique_ptr<HttpServer> HttpServer::start(const HttpServerConfig& config, std::map<std::string, HttpHandler> routes, std::string* error) {
  std::call_once(library_once, [] { mg_init_library(0); });
  std::unique_ptr<HttpServer> server(new HttpServer());
  server->context_ = std::make_unique<Context>();
  server->context_->routes = std::move(routes);
  const std::string ports = config.listen.address + ":" + std::to_string(config.listen.port);
  const std::string threads = std::to_string(std::max(1, config.threads));
  const std::string timeout = std::to_string(std::max(100, config.request_timeout_ms));
  // No document_root: civetweb serves no file. No keep-alive: each scrape is one short connection.
  const char* options[] = {"listening_ports", ports.c_str(),       "num_threads", threads.c_str(), "request_timeout_ms",
                           timeout.c_str(),   "enable_keep_alive", "no",          nullptr};
  mg_callbacks callbacks;
  std::memset(&callbacks, 0, sizeof callbacks);
  callbacks.log_message = quiet_log;
  server->context_->ctx = mg_start(&callbacks, nullptr, options);
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

HttpServer::~HttpServer() {
  if (context_ && context_->ctx) mg_stop(context_->ctx);
}

std::string HttpServer::url() const { return "http://" + address_ + ":" + std::to_string(port_); }

}  // namespace loopd
