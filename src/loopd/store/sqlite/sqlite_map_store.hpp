#pragma once
/// @file The SQLite back end of the map store (it registers itself for open_map_store()). No SQLite header here.
#include "loopd/store/map_store.hpp"

namespace loopd {

/// @brief Schema version of the SQLite map (`PRAGMA user_version`); a map with another version is refused.
/// 2: keyframes.place (Scan Context); 3: table map_clouds. Older maps are upgraded on a writable open.
inline constexpr int kSqliteMapSchemaVersion = 7;

/// @brief Opens or creates the SQLite map `config.uri` names ("FILE", "sqlite://FILE" or "sqlite::memory:"). WAL
/// journal, `synchronous` from the config, foreign keys on; a map of another schema version is refused (kCorrupt).
OpenedMapStore open_sqlite_map_store(const MapStoreConfig& config);
/// @brief The same for the file `path` (or ":memory:") that parse_store_uri() found in config.uri.
OpenedMapStore open_sqlite_map_store(const MapStoreConfig& config, const std::string& path);

}  // namespace loopd
