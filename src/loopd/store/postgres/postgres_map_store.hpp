#pragma once
/// @file The PostgreSQL back end of the map store: one map shared by a fleet (open_map_store() dispatches
/// "postgresql://" and "postgres://" URIs to it). No libpq or libpqxx header here.
#include "loopd/store/map_store.hpp"

namespace loopd {

/// @brief Schema version of a PostgreSQL map (table loopd_meta); a map with another version is refused.
inline constexpr int kPostgresMapSchemaVersion = 5;

/// @brief Connects to the libpq URI `config.uri` and creates loopd's tables when the database has none (several
/// processes may do so at once; read_only never creates them: kNotFound). Scoped to `config.vehicle` (map_store.hpp).
/// The connection's password never appears in a message. A server that cannot be reached: kUnavailable; refused
/// credentials or a missing database: kInvalid.
/// @note stats().bytes is the whole database's size (pg_database_size), also for a store scoped to one vehicle.
/// @note Inside begin() .. commit(), a statement that fails (say a repeated key) aborts the whole server-side
/// transaction, unlike SQLite's: roll back and write again.
OpenedMapStore open_postgres_map_store(const MapStoreConfig& config);

/// @brief `uri` with its password replaced by "***" (for messages).
std::string mask_password(const std::string& uri);

}  // namespace loopd
