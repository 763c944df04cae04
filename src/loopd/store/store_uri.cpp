#include "loopd/store/store_uri.hpp"

#include <algorithm>
#include <cctype>

namespace loopd {

StoreUri parse_store_uri(const std::string& uri) {
  if (uri == "sqlite::memory:") return {"sqlite", ":memory:"};
  const auto sep = uri.find("://");
  if (sep == std::string::npos) return {"sqlite", uri};
  std::string scheme = uri.substr(0, sep);
  std::transform(scheme.begin(), scheme.end(), scheme.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (scheme == "postgresql" || scheme == "postgres") return {"postgresql", uri};
  return {scheme, uri.substr(sep + 3)};
}

bool names_shared_map(const std::string& uri) { return parse_store_uri(uri).scheme == "postgresql"; }

}  // namespace loopd
