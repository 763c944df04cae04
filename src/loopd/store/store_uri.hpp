#pragma once
/// @file The one parse of a map URI: which back end it names and what that back end is given.
#include <string>

namespace loopd {

/// @brief A map URI taken apart. Forms: "FILE" and "sqlite://FILE" (scheme "sqlite", location FILE),
/// "sqlite::memory:" ("sqlite", ":memory:"), "postgresql://..." and "postgres://..." ("postgresql", the whole URI,
/// which libpq reads itself), "OTHER://REST" ("OTHER", REST: a back end this build may not have).
struct StoreUri {
  std::string scheme;    ///< lower case, without "://"
  std::string location;  ///< what the back end opens: a file name, ":memory:", or the server URI
  /// The location is a file on this machine (its size is the file's, its absence is "no such file").
  bool is_file() const { return scheme == "sqlite" && location != ":memory:" && !location.empty(); }
};

/// @brief Parses `uri` (never fails: an unknown scheme is reported by open_map_store, an empty one by validate()).
StoreUri parse_store_uri(const std::string& uri);

/// @brief The URI names a map that several writers share (a fleet map: the PostgreSQL back end).
bool names_shared_map(const std::string& uri);

}  // namespace loopd
