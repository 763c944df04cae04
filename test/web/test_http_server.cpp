// loopd's HTTP endpoints' server (src/loopd/web): a real server on a loopback port, real sockets.
#include <catch2/catch.hpp>

#include <atomic>
#include <string>

#include "loopd/web/http_server.hpp"
#include "loopd/web/metrics_text.hpp"
#include "support/http_client.hpp"

using namespace loopd;
using loopd::test::http_exchange;
using loopd::test::http_request;

TEST_CASE("http listen: PORT or IPV4:PORT, loopback by default, anything else refused with the text named") {
  std::string error;
  const auto p = parse_http_listen("8080", &error);
  REQUIRE(p);
  CHECK(p->address == "127.0.0.1");
  CHECK(p->port == 8080);
  const auto a = parse_http_listen("0.0.0.0:9100", &error);
  REQUIRE(a);
  CHECK(a->address == "0.0.0.0");
  CHECK(a->port == 9100);
  for (const char* bad : {"", "http://x:80", "localhost:80", "1.2.3:80", "256.1.1.1:80", "80000", "1.2.3.4:", ":80", "8080 ", "-1"}) {
    INFO(bad);
    error.clear();
    CHECK_FALSE(parse_http_listen(bad, &error));
    CHECK(error.find(std::string("'") + bad + "'") != std::string::npos);
  }
}

TEST_CASE("http server: its routes answer GET and HEAD, other paths 404, other methods 405, hostile requests never reach a file") {
  std::atomic<int> calls{0};
  std::string error;
  HttpServerConfig config;  // 127.0.0.1, port 0: a free one
  auto server = HttpServer::start(config,
                                  {{"/metrics",
                                    [&] {
                                      ++calls;
                                      return HttpResponse{200, MetricsText::content_type(), "loopd_up 1\n"};
                                    }},
                                   {"/boom", []() -> HttpResponse { throw std::runtime_error("no status yet"); }}},
                                  &error);
  REQUIRE(server);
  INFO(server->url());
  REQUIRE(server->port() > 0);
  CHECK(server->url() == "http://127.0.0.1:" + std::to_string(server->port()));

  const auto ok = http_request(server->port(), "GET", "/metrics");
  CHECK(ok.status == 200);
  CHECK(ok.body == "loopd_up 1\n");
  CHECK(ok.headers.find("Content-Type: text/plain; version=0.0.4") != std::string::npos);
  const auto head = http_request(server->port(), "HEAD", "/metrics");
  CHECK(head.status == 200);
  CHECK(head.body.empty());
  CHECK(calls == 2);
  CHECK(http_request(server->port(), "GET", "/metrics?x=1").status == 200);  // a query string is not another path
  CHECK(http_request(server->port(), "GET", "/").status == 404);
  CHECK(http_request(server->port(), "GET", "/metricsx").status == 404);
  CHECK(http_request(server->port(), "GET", "/../../etc/passwd").status == 404);
  CHECK(http_request(server->port(), "GET", "/metrics/../../etc/passwd").status == 404);
  const auto post = http_request(server->port(), "POST", "/metrics");
  CHECK(post.status == 405);
  CHECK(post.headers.find("Allow: GET, HEAD") != std::string::npos);
  const auto boom = http_request(server->port(), "GET", "/boom");
  CHECK(boom.status == 500);
  CHECK(boom.body == "error: no status yet\n");
  // Garbage and a header far too long get an error or a closed connection, and the server goes on.
  CHECK(http_exchange(server->port(), "\x01\x02 garbage\r\n\r\n").status != 200);
  CHECK(http_exchange(server->port(), "GET /metrics HTTP/1.1\r\nX: " + std::string(100000, 'a') + "\r\n\r\n").status != 200);
  CHECK(http_request(server->port(), "GET", "/metrics").status == 200);

  // A second server on the same port is refused with a reason.
  HttpServerConfig same = config;
  same.listen.port = server->port();
  error.clear();
  CHECK_FALSE(HttpServer::start(same, {}, &error));
  CHECK(error.find("cannot listen on 127.0.0.1:" + std::to_string(server->port())) != std::string::npos);
  const int port = server->port();
  server.reset();  // stopped: nothing answers
  CHECK(http_request(port, "GET", "/metrics").status == 0);
}

TEST_CASE("metrics text: HELP, TYPE and one sample per family, integers exact, label values and help escaped") {
  MetricsText m;
  m.counter("loopd_loops_accepted_total", "Loops accepted.", 118);
  m.gauge("loopd_resident_memory_bytes", "Resident memory [bytes].", 158334976);
  m.gauge("loopd_uptime_seconds", "Seconds since start.", 2.5);
  m.gauge("loopd_descriptor_device_info", "The descriptor device\nin use.", 1, "device", "pthread \"cpu\"\\");
  CHECK(m.text() ==
        "# HELP loopd_loops_accepted_total Loops accepted.\n# TYPE loopd_loops_accepted_total counter\nloopd_loops_accepted_total 118\n"
        "# HELP loopd_resident_memory_bytes Resident memory [bytes].\n# TYPE loopd_resident_memory_bytes gauge\n"
        "loopd_resident_memory_bytes 158334976\n"
        "# HELP loopd_uptime_seconds Seconds since start.\n# TYPE loopd_uptime_seconds gauge\nloopd_uptime_seconds 2.5\n"
        "# HELP loopd_descriptor_device_info The descriptor device\\nin use.\n# TYPE loopd_descriptor_device_info gauge\n"
        "loopd_descriptor_device_info{device=\"pthread \\\"cpu\\\"\\\\\"} 1\n");
}
