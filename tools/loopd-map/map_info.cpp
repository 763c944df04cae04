// loopd-map info: what a map holds.
#include <iostream>
#include <map>

#include "map_commands.hpp"
#include "tool_output.hpp"

namespace loopd::tools {
namespace {

/// @brief Keyframe totals a walk over the keyframes finds (MapStats has no per-feature count).
struct KeyframeCounts {
  std::int64_t keyframes = 0, with_features = 0, usable_features = 0;
  std::map<SessionId, std::int64_t> first_utime;  ///< [us] each session's first keyframe
};

StoreStatus count_keyframes(MapStore& store, std::int64_t total, bool progress, KeyframeCounts* counts) {
  Progress bar("reading keyframes", total, progress);
  const StoreStatus read = store.for_each_keyframe(std::nullopt, KeyframeLoad::kDescriptor, [&](MapKeyframe&& k) {
    ++counts->keyframes;
    counts->first_utime.emplace(k.record.key.session, k.record.utime);
    if (k.record.features) ++counts->with_features;
    if (k.record.features && k.record.features->ok) ++counts->usable_features;
    bar.update(counts->keyframes);
  });
  bar.finish();
  return read;
}

/// @brief The session's first utime: as stored, or its first keyframe's when the record still holds 0 (unknown).
std::int64_t first_utime(const SessionRecord& s, const KeyframeCounts& counts) {
  const auto it = counts.first_utime.find(s.id);
  return s.first_utime != 0 || it == counts.first_utime.end() ? s.first_utime : it->second;
}

std::string sessions_table(const std::vector<SessionRecord>& sessions, const KeyframeCounts& counts) {
  Table table({"session", "sensor", "source", "first utime [us]", "anchored"});
  for (const SessionRecord& s : sessions)
    table.add({std::to_string(s.id), s.sensor, s.source, std::to_string(first_utime(s, counts)), s.anchored ? "yes" : "no"});
  return table.str();
}

nlohmann::json sessions_json(const std::vector<SessionRecord>& sessions, const KeyframeCounts& counts) {
  nlohmann::json list = nlohmann::json::array();
  for (const SessionRecord& s : sessions)
    list.push_back({{"id", s.id}, {"sensor", s.sensor}, {"source", s.source}, {"first_utime", first_utime(s, counts)}, {"anchored", s.anchored}});
  return list;
}

}  // namespace

int run_info(MapStore& store, const CommandOptions& options) {
  const StoreResult<MapStats> stats = store.stats();
  const StoreResult<std::vector<SessionRecord>> sessions = store.sessions();
  const StoreResult<std::optional<CorrectionRecord>> correction = store.correction();
  const StoreResult<std::vector<LoopLedgerEntry>> ledger = store.loop_ledger();
  for (const StoreStatus* s : {&stats.status, &sessions.status, &correction.status, &ledger.status}) {
    if (s->ok()) continue;
    std::cerr << "loopd-map: " << s->message << "\n";
    return kExitBadInput;
  }
  KeyframeCounts counts;
  if (const StoreStatus read = count_keyframes(store, stats.value.keyframes, options.progress, &counts); !read.ok()) {
    std::cerr << "loopd-map: " << read.message << "\n";
    return kExitBadInput;
  }
  const MapStats& m = stats.value;
  const std::int64_t revision = correction.value ? correction.value->revision : 0;
  std::cout << "map " << store.uri() << "\n" << sessions_table(sessions.value, counts);
  Table totals({"", "count"});
  totals.add({"sessions", std::to_string(m.sessions)});
  totals.add({"keyframes", std::to_string(m.keyframes)});
  totals.add({"keyframes retired (pose rows only)", std::to_string(m.keyframes_retired)});
  totals.add({"keyframes with features", std::to_string(counts.with_features)});
  totals.add({"keyframes with usable features", std::to_string(counts.usable_features)});
  totals.add({"loops accepted", std::to_string(m.loops_accepted)});
  totals.add({"loops rejected", std::to_string(m.loops_rejected)});
  totals.add({"loops revoked (loop ledger)", std::to_string(m.loops_revoked)});
  totals.add({"correction revision", correction.value ? std::to_string(revision) : "none"});
  totals.add({"keyframes in the correction", correction.value ? std::to_string(correction.value->keys.size()) : "0"});
  const std::int64_t correction_seq = correction.value ? correction.value->ledger_seq : 0, ledger_seq = newest_seq(ledger.value);
  totals.add({"loop ledger entries (the correction honours up to)", std::to_string(ledger_seq) + " (" + std::to_string(correction_seq) + ")"});
  const std::string per =
      m.map_clouds > 0 ? fmt(static_cast<double>(m.map_cloud_bytes) / static_cast<double>(m.map_clouds) / 1024.0, 1) + " KiB each" : "-";
  totals.add(
      {"keyframes with a map cloud (points, bytes)", std::to_string(m.map_clouds) + " (" + std::to_string(m.map_cloud_points) + ", " + per + ")"});
  totals.add({"bytes on disk", std::to_string(m.bytes) + " (" + fmt(static_cast<double>(m.bytes) / 1048576.0, 1) + " MiB)"});
  std::cout << totals.str();
  if (correction.value && correction_seq < ledger_seq)
    std::cout << "the loop ledger changed after the correction: `loopd-map " << store.uri()
              << " correct` (or loopd at its next start, or a running loopd) makes it again\n";
  if (options.json) {
    print_json_line({{"map", store.uri()},
                     {"sessions", m.sessions},
                     {"session_list", sessions_json(sessions.value, counts)},
                     {"keyframes", m.keyframes},
                     {"keyframes_retired", m.keyframes_retired},
                     {"keyframes_with_features", counts.with_features},
                     {"keyframes_with_usable_features", counts.usable_features},
                     {"loops_accepted", m.loops_accepted},
                     {"loops_rejected", m.loops_rejected},
                     {"loops_revoked", m.loops_revoked},
                     {"ledger_seq", ledger_seq},
                     {"correction_ledger_seq", correction_seq},
                     {"correction_revision", revision},
                     {"correction_keyframes", correction.value ? correction.value->keys.size() : 0},
                     {"map_clouds", m.map_clouds},
                     {"map_cloud_points", m.map_cloud_points},
                     {"map_cloud_bytes", m.map_cloud_bytes},
                     {"bytes", m.bytes}});
  }
  return kExitOk;
}

}  // namespace loopd::tools
