#pragma once
/// @file Opening a map for reading only: never creates a file, and says why a path is not a readable map.
#include <memory>
#include <string>

#include "loopd/store/map_store.hpp"

namespace loopd::tools {

/// @brief The opened map, or error naming the file (store null).
struct ReadOnlyMap {
  std::unique_ptr<MapStore> store;
  std::string error;
};

/// @brief Opens `path` ("FILE", "sqlite://FILE" or a "postgresql://" URI: the whole fleet's map) read-only. A missing path, a directory, an empty
/// file, a file that is not a loopd map and a map of another schema version are errors.
/// @param writable open it for writing instead (the loop ledger, correct): still never created, and a map of an older
///        schema this build knows is upgraded as loopd upgrades it.
ReadOnlyMap open_map_read_only(const std::string& path, bool writable = false);

}  // namespace loopd::tools
