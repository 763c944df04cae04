#include "loopd/map/map_store.hpp"

#include "loopd/map/sqlite_map_store.hpp"
#if LOOPD_WITH_POSTGRES
#include "loopd/map/postgres/postgres_map_store.hpp"
#endif

namespace loopd {
namespace {

bool starts_with(const std::string& s, const std::string& prefix) { return s.compare(0, prefix.size(), prefix) == 0; }

}  // namespace

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

OpenedMapStore open_map_store(const MapStoreConfig& config) {
  OpenedMapStore out;
  if (const auto error = config.validate()) {
    out.status = {StoreStatus::Code::kInvalid, *error};
    return out;
  }
  const std::string& uri = config.uri;
  if (starts_with(uri, "postgresql://") || starts_with(uri, "postgres://")) {
#if LOOPD_WITH_POSTGRES
    return open_postgres_map_store(config);
#else
    out.status = {StoreStatus::Code::kInvalid,
                  "map uri names a PostgreSQL server, but this loopd is built without PostgreSQL (libpqxx-dev, cmake -DLOOPD_WITH_POSTGRES=ON)"};
    return out;
#endif
  }
  if (uri.find("://") != std::string::npos && !starts_with(uri, "sqlite://")) {
    out.status = {StoreStatus::Code::kInvalid, "map " + uri + ": unknown scheme (a file name, sqlite://FILE or sqlite::memory:)"};
    return out;
  }
  return open_sqlite_map_store(config);
}

}  // namespace loopd
