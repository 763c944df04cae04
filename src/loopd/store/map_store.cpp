#include "loopd/store/map_store.hpp"

#include <algorithm>

#include "loopd/store/store_uri.hpp"

namespace loopd {

std::optional<std::string> MapStoreConfig::validate() const {
  if (uri.empty()) return "map uri is empty (a file name, sqlite://FILE, sqlite::memory: or postgresql://...)";
  if (synchronous != "normal" && synchronous != "full") return "map synchronous is \"" + synchronous + "\": expected normal or full";
  if (busy_timeout_ms < 0) return "map busy_timeout_ms is negative";
  if (max_pages < 0) return "map max_pages is negative";
  if (uri == "sqlite://") return "map uri sqlite:// names no file";
  return std::nullopt;
}

const char* to_string(StoreStatus::Code code) {
  switch (code) {
    case StoreStatus::Code::kOk:
      return "kOk";
    case StoreStatus::Code::kNotFound:
      return "kNotFound";
    case StoreStatus::Code::kBusy:
      return "kBusy";
    case StoreStatus::Code::kCorrupt:
      return "kCorrupt";
    case StoreStatus::Code::kIo:
      return "kIo";
    case StoreStatus::Code::kInvalid:
      return "kInvalid";
    case StoreStatus::Code::kUnavailable:
      return "kUnavailable";
  }
  return "unknown";
}

std::vector<MapStoreBackend>& backends() {
  static std::vector<MapStoreBackend> registered;  // filled by the back ends' static registrars, before main
  return registered;
}

bool register_map_store_backend(const MapStoreBackend& backend) {
  std::vector<MapStoreBackend>& all = backends();
  const auto same = std::find_if(all.begin(), all.end(), [&](const MapStoreBackend& b) { return b.scheme == backend.scheme; });
  if (same != all.end())
    *same = backend;
  else
    all.push_back(backend);
  return true;
}

const MapStoreBackend* find_map_store_backend(const std::string& scheme) {
  for (const MapStoreBackend& b : backends())
    if (b.scheme == scheme) return &b;
  return nullptr;
}

std::string map_store_schemes() {
  std::vector<std::string> schemes;
  for (const MapStoreBackend& b : backends()) schemes.push_back(b.scheme);
  std::sort(schemes.begin(), schemes.end());
  std::string out;
  for (const std::string& scheme : schemes) out += (out.empty() ? "" : ", ") + scheme;
  return out.empty() ? "none" : out;
}

OpenedMapStore open_map_store(const MapStoreConfig& config) {
  OpenedMapStore out;
  if (const auto error = config.validate()) {
    out.status = {StoreStatus::Code::kInvalid, *error};
    return out;
  }
  const StoreUri uri = parse_store_uri(config.uri);
  const MapStoreBackend* backend = find_map_store_backend(uri.scheme);
  if (!backend) {
    const std::string hint = uri.scheme == "postgresql" ? " (PostgreSQL needs libpqxx-dev and cmake -DLOOPD_WITH_POSTGRES=ON)" : "";
    out.status = {StoreStatus::Code::kInvalid,
                  "map " + config.uri + ": unknown scheme \"" + uri.scheme + "\" (this build opens " + map_store_schemes() + ")" + hint};
    return out;
  }
  return backend->open(config, uri.location);
}

}  // namespace loopd
