#pragma once
/// @file The PostgreSQL map's tables (schema kPostgresMapSchemaVersion). Same ideas as the SQLite map: blobs in the
/// same encodings (record_blobs.hpp, keyframe_codec, map_cloud_codec); loops keyed by the writing vehicle and its
/// event id (every loopd numbers its events from 0); one correction row per vehicle (its detector's, for resume);
/// the fleet's joint corrections as revisions. stored_at: when a row reached the server (latency figures).
namespace loopd::postgres {

inline constexpr const char* kSchema = R"sql(
CREATE TABLE loopd_meta (key text PRIMARY KEY, value text NOT NULL);
CREATE TABLE sessions (
  id integer PRIMARY KEY, first_utime bigint NOT NULL, sensor text NOT NULL, source text NOT NULL,
  T_map_session bytea NOT NULL, anchored boolean NOT NULL);
CREATE TABLE keyframes (
  session integer NOT NULL REFERENCES sessions(id), idx bigint NOT NULL, utime bigint NOT NULL,
  T_odom_sensor bytea NOT NULL, T_map_sensor bytea NOT NULL, residual float8 NOT NULL, travelled float8 NOT NULL,
  decided boolean NOT NULL DEFAULT false, has_features boolean NOT NULL, features_ok boolean NOT NULL,
  features_error text NOT NULL, input_points bigint NOT NULL, invalid_points bigint NOT NULL,
  ms_descriptor float8 NOT NULL, ms_prepare float8 NOT NULL, descriptor bytea NOT NULL, place bytea NOT NULL,
  features bytea NOT NULL, stored_at timestamptz NOT NULL DEFAULT clock_timestamp(),
  scan_fingerprint bigint NOT NULL DEFAULT 0, step bytea, retired boolean NOT NULL DEFAULT false,
  PRIMARY KEY (session, idx));
CREATE TABLE map_clouds (
  session integer NOT NULL, idx bigint NOT NULL, points bigint NOT NULL, cloud bytea NOT NULL,
  PRIMARY KEY (session, idx), FOREIGN KEY (session, idx) REFERENCES keyframes (session, idx) ON DELETE CASCADE);
CREATE TABLE loops (
  vehicle integer NOT NULL, event_id bigint NOT NULL, query_session integer NOT NULL, query_idx bigint NOT NULL,
  match_session integer NOT NULL, match_idx bigint NOT NULL, query_utime bigint NOT NULL, match_utime bigint NOT NULL,
  status integer NOT NULL, stage text NOT NULL, reason text NOT NULL, gate_distance float8, gate_radius float8,
  descriptor_distance float8, lcp_fraction float8, icp_residual float8, icp_fitness float8,
  hungarian_consistency float8, degeneracy float8, T_match_query bytea NOT NULL, information bytea NOT NULL,
  retrieval text NOT NULL, place_distance float8, confirmed boolean NOT NULL, published boolean NOT NULL DEFAULT true,
  stored_at timestamptz NOT NULL DEFAULT clock_timestamp(), PRIMARY KEY (vehicle, event_id));
CREATE INDEX loops_query ON loops (query_session, query_idx);
CREATE TABLE correction (
  vehicle integer PRIMARY KEY, revision bigint NOT NULL, loop_event_id bigint NOT NULL, method text NOT NULL,
  T_map_odom bytea NOT NULL, keys bytea NOT NULL, poses bytea NOT NULL, corrector_state bytea NOT NULL,
  ledger_seq bigint NOT NULL DEFAULT 0);
CREATE TABLE loop_ledger (
  seq bigserial PRIMARY KEY, vehicle integer NOT NULL, event_id bigint NOT NULL, revoked boolean NOT NULL, who text NOT NULL,
  reason text NOT NULL, utime bigint NOT NULL, stored_at timestamptz NOT NULL DEFAULT clock_timestamp());
CREATE INDEX loop_ledger_by_event ON loop_ledger (vehicle, event_id, seq);
CREATE TABLE fleet_corrections (
  revision bigint PRIMARY KEY, solver_vehicle integer NOT NULL, loops bigint NOT NULL, solved_utime bigint NOT NULL,
  keys bytea NOT NULL, poses bytea NOT NULL, utimes bytea NOT NULL, sessions bytea NOT NULL,
  stored_at timestamptz NOT NULL DEFAULT clock_timestamp());
)sql";

/// Keyframe columns written by put_keyframe; the bulk reads add `retired`, then `features` at KeyframeLoad::kFull.
inline constexpr const char* kKeyframeColumns =
    "session, idx, utime, T_odom_sensor, T_map_sensor, residual, travelled, has_features, features_ok, features_error, "
    "input_points, invalid_points, ms_descriptor, ms_prepare, descriptor, place, scan_fingerprint, step";

/// Schema upgrades, from version i + 1 to i + 2 (run under the schema lock, with the version row updated).
/// 1 -> 2: the keyframes' scan fingerprints (0 before: a replay resume matches those by time and pose alone).
/// 2 -> 3: the keyframes' steps measured by the scans (none before: the odometry's steps are used there).
/// 3 -> 4: the loop ledger (empty before) and the ledger entry each vehicle's correction accounts for.
/// 4 -> 5: retired keyframes (none before).
inline constexpr const char* kSchemaUpgrades[] = {
    "ALTER TABLE keyframes ADD COLUMN scan_fingerprint bigint NOT NULL DEFAULT 0; "
    "ALTER TABLE loops ADD COLUMN published boolean NOT NULL DEFAULT true",
    "ALTER TABLE keyframes ADD COLUMN step bytea",
    "ALTER TABLE correction ADD COLUMN ledger_seq bigint NOT NULL DEFAULT 0; "
    "CREATE TABLE loop_ledger (seq bigserial PRIMARY KEY, vehicle integer NOT NULL, event_id bigint NOT NULL, revoked boolean NOT NULL, "
    "who text NOT NULL, reason text NOT NULL, utime bigint NOT NULL, stored_at timestamptz NOT NULL DEFAULT clock_timestamp()); "
    "CREATE INDEX loop_ledger_by_event ON loop_ledger (vehicle, event_id, seq)",
    "ALTER TABLE keyframes ADD COLUMN retired boolean NOT NULL DEFAULT false",
};

inline constexpr const char* kLoopColumns =
    "event_id, query_session, query_idx, match_session, match_idx, query_utime, match_utime, status, stage, reason, "
    "gate_distance, gate_radius, descriptor_distance, lcp_fraction, icp_residual, icp_fitness, hungarian_consistency, "
    "degeneracy, T_match_query, information, retrieval, place_distance, confirmed, published";

/// Advisory lock keys: creating the schema, the solver role, numbering joint corrections.
inline constexpr long long kSchemaLock = 0x6c6f6f7064000001LL;
inline constexpr long long kSolverLock = 0x6c6f6f7064000002LL;
inline constexpr long long kRevisionLock = 0x6c6f6f7064000003LL;

}  // namespace loopd::postgres
