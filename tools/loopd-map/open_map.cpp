#include "open_map.hpp"

#include "loopd/store/store_uri.hpp"

#include <sys/stat.h>

namespace loopd::tools {

namespace {

/// @brief The whole fleet's map on a PostgreSQL server (unscoped: every vehicle), in read-only transactions.
ReadOnlyMap open_postgres_read_only(const std::string& uri, bool writable) {
  ReadOnlyMap out;
  MapStoreConfig config;
  config.uri = uri;
  config.read_only = !writable;
  OpenedMapStore opened = open_map_store(config);
  if (!opened.status.ok())
    out.error = opened.status.message;  // names the URI with its password masked
  else
    out.store = std::move(opened.store);
  return out;
}

}  // namespace

ReadOnlyMap open_map_read_only(const std::string& path, bool writable) {
  const StoreUri uri = parse_store_uri(path);
  if (names_shared_map(path)) return open_postgres_read_only(path, writable);
  ReadOnlyMap out;
  const std::string& file = uri.location;
  if (!uri.is_file()) {
    out.error = "map " + path + ": expected a map file (FILE or sqlite://FILE) or postgresql://...";
    return out;
  }
  // Checked here, before SQLite: a read-only open never creates the file, but the message should name the cause.
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) {
    out.error = "map " + file + ": no such file";
    return out;
  }
  if (S_ISDIR(st.st_mode)) {
    out.error = "map " + file + ": is a directory, not a map file";
    return out;
  }
  if (st.st_size == 0) {
    out.error = "map " + file + ": is empty (0 bytes), not a loopd map";
    return out;
  }
  MapStoreConfig config;
  config.uri = path;
  config.read_only = !writable;
  OpenedMapStore opened = open_map_store(config);
  if (!opened.status.ok()) {
    out.error = opened.status.message.empty() ? "map " + file + ": cannot open (" + to_string(opened.status.code) + ")" : opened.status.message;
    return out;
  }
  out.store = std::move(opened.store);
  return out;
}

}  // namespace loopd::tools
