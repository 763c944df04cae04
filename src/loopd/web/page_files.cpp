#include "loopd/web/page_files.hpp"

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <unistd.h>

namespace loopd {
namespace {

bool has_index(const std::string& dir) { return !dir.empty() && std::ifstream(dir + "/index.html").good(); }

/// The folder of the running program.
std::string program_dir() {
  char path[4096];
  const ssize_t n = readlink("/proc/self/exe", path, sizeof path - 1);
  if (n <= 0) return "";
  const std::string exe(path, static_cast<std::size_t>(n));
  return exe.substr(0, exe.rfind('/'));
}

HttpHandler file(const std::string& path, const char* content_type) {
  return [path, content_type] {
    std::ifstream in(path, std::ios::binary);
    if (!in) return HttpResponse{404, "text/plain; charset=utf-8", "not installed: " + path.substr(path.rfind('/') + 1) + "\n"};
    std::ostringstream body;
    body << in.rdbuf();
    return HttpResponse{200, content_type, body.str()};
  };
}

}  // namespace

std::string find_page_dir() {
  if (const char* env = std::getenv("LOOPD_PAGE_DIR"); env && has_index(env)) return env;
  if (const std::string installed = program_dir() + "/../share/loopd/page"; has_index(installed)) return installed;
#ifdef LOOPD_PAGE_SOURCE_DIR
  if (has_index(LOOPD_PAGE_SOURCE_DIR)) return LOOPD_PAGE_SOURCE_DIR;
#endif
  return "";
}

std::map<std::string, HttpHandler> page_routes(const std::string& page_dir) {
  const char* js = "text/javascript; charset=utf-8";
  return {{"/", file(page_dir + "/index.html", "text/html; charset=utf-8")},
          {"/view.js", file(page_dir + "/view.js", js)},
          {"/view.css", file(page_dir + "/view.css", "text/css; charset=utf-8")},
          {"/lib/three.min.js", file("/usr/share/javascript/three/build/three.min.js", js)},
          {"/lib/OrbitControls.js", file("/usr/share/javascript/three/examples/js/controls/OrbitControls.js", js)},
          {"/lib/chart.min.js", file("/usr/share/javascript/chart.js/chart.min.js", js)}};
}

}  // namespace loopd
