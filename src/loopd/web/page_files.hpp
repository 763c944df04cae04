#pragma once
/// @file The live page's files: a fixed table from URL path to file (the page's own folder, and Debian's libjs-three
/// and libjs-chart.js where they are installed). No URL is ever turned into a file name, so no request reaches a file
/// outside the table.
#include <map>
#include <string>

#include "loopd/web/http_server.hpp"

namespace loopd {

/// @brief The folder of the page: $LOOPD_PAGE_DIR, else ../share/loopd/page beside the running program (installed),
/// else the source tree's src/loopd/web/page (a build tree); "" when none holds index.html.
std::string find_page_dir();

/// @brief Routes for "/", "/view.js", "/view.css" (from `page_dir`) and "/lib/three.min.js", "/lib/OrbitControls.js",
/// "/lib/chart.min.js" (Debian's /usr/share/javascript). A file missing at request time answers 404.
std::map<std::string, HttpHandler> page_routes(const std::string& page_dir);

}  // namespace loopd
