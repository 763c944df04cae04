// loopd-map FILE serve --http ADDR:PORT: the live page for a stored map (its sessions, every stored decision, the
// newest keyframes' map clouds) without a running loopd, until SIGINT or SIGTERM.
#include <chrono>
#include <csignal>
#include <iostream>
#include <thread>

#include "loopd/runtime/view_sink.hpp"
#include "loopd/web/page_files.hpp"
#include "loopd/web/view_clients.hpp"
#include "map_commands.hpp"

namespace loopd::tools {
namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

}  // namespace

int run_serve(MapStore& store, const ServeOptions& serve, const CommandOptions& options) {
  std::string error;
  const std::optional<HttpListen> listen = parse_http_listen(serve.listen, &error);
  if (!listen) {
    std::cerr << "loopd-map: --http " << error << "\n";
    return kExitBadInput;
  }
  ViewFeed feed;
  feed.set_source("map " + store.uri());
  MapViewOptions view;
  view.clouds = serve.clouds;
  if (const StoreStatus s = load_map_view(store, feed, view); !s.ok()) {
    std::cerr << "loopd-map: " << s.message << "\n";
    return kExitBadInput;
  }
  const StoreResult<MapStats> stats = store.stats();
  if (stats.ok()) {
    const auto v = [](std::int64_t x) { return static_cast<double>(x); };
    feed.set_health({{"keyframes", v(stats.value.keyframes)},
                     {"loops_accepted", v(stats.value.loops_accepted)},
                     {"loops_rejected", v(stats.value.loops_rejected)},
                     {"loops_revoked", v(stats.value.loops_revoked)},
                     {"keyframes_retired", v(stats.value.keyframes_retired)},
                     {"sessions", v(stats.value.sessions)},
                     {"map_clouds", v(stats.value.map_clouds)},
                     {"map_bytes", v(stats.value.bytes)}},
                    {{"map", store.uri()}, {"role", "a stored map (loopd-map serve)"}});
  }
  if (find_page_dir().empty()) std::cerr << "loopd-map: warning: the page's files were not found (set LOOPD_PAGE_DIR)\n";
  ViewClientsConfig clients_config;
  clients_config.max_clients = serve.clients;
  ViewClients clients(feed, clients_config);
  HttpServerConfig config;
  config.listen = *listen;
  config.websocket_clients = serve.clients;
  config.threads = 2 + serve.clients;
  std::unique_ptr<HttpServer> server = HttpServer::start(config, page_routes(find_page_dir()), &error);
  if (!server) {
    std::cerr << "loopd-map: --http " << serve.listen << ": " << error << "\n";
    return kExitBadInput;
  }
  server->add_websocket("/ws", clients.service());
  const ViewFeed::Counts counts = feed.counts();
  std::cout << "serving " << store.uri() << " at " << server->url() << "/ (" << counts.keyframes << " keyframes, " << counts.accepted
            << " accepted loops, " << counts.decisions << " decisions); Ctrl-C stops" << std::endl;
  if (options.json) {
    nlohmann::json j = {
        {"url", server->url() + "/"}, {"keyframes", counts.keyframes}, {"loops_accepted", counts.accepted}, {"decisions", counts.decisions}};
    std::cout << j.dump() << std::endl;
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  server.reset();  // before the clients: its callbacks reach them
  return kExitOk;
}

}  // namespace loopd::tools
