#include "loopd/runtime/map_resume.hpp"

#include <algorithm>
#include <set>

#include "loopd/base/stopwatch.hpp"
#include "loopd/correction/loop_corrector.hpp"

namespace loopd {
namespace {

/// @brief The stored correction and its decoded corrector state, when the map has one.
struct StoredCorrection {
  bool present = false;
  CorrectionRecord record;
  CorrectorResumeState state;
};

std::optional<std::string> read_correction(MapStore& store, StoredCorrection* out) {
  const StoreResult<std::optional<CorrectionRecord>> read = store.correction();
  if (!read.ok()) return read.status.message;
  if (!read.value) return std::nullopt;
  const DecodedResumeState state = decode_resume_state(read.value->corrector_state);
  if (!state.ok) return store.uri() + ": correction revision " + std::to_string(read.value->revision) + ": " + state.error;
  out->present = true;
  out->record = *read.value;
  out->state = state.state;
  return std::nullopt;
}

std::optional<std::string> read_loops(MapStore& store, std::vector<LoopDecision>* loops) {
  const StoreStatus s = store.for_each_loop(false, [&](LoopDecision&& r) { loops->push_back(std::move(r)); });
  if (!s.ok()) return s.message;
  return std::nullopt;
}

/// @brief Restores the decisions `query` made (they follow its keyframe in event order): the ones the stored
/// correction covers are counted again, later accepted ones are corrected again.
/// `revoked`: the loops the ledger had revoked when the stored correction was made (kept out of the graph, as then).
std::optional<std::string> restore_decisions(const KeyframeKey& query, const std::vector<LoopDecision>& loops, std::size_t* next,
                                             const StoredCorrection& stored, const std::set<std::int64_t>& revoked, LoopDetector& detector,
                                             ResumeSummary& summary) {
  for (; *next < loops.size() && loops[*next].query == query; ++*next) {
    const LoopDecision& d = loops[*next];
    ++summary.decisions;
    const bool out_of_graph = d.accepted() && revoked.count(d.event_id) > 0;
    if (d.status == LoopStatus::kAccepted && !out_of_graph && (!stored.present || d.event_id > stored.record.loop_event_id)) {
      if (auto c = detector.reapply_loop(d, d.information)) summary.corrections.push_back(std::move(*c));
      continue;
    }
    detector.restore_decision(d, d.information, out_of_graph);
    if (!stored.present || d.event_id != stored.record.loop_event_id) continue;
    if (!stored.record.keys.empty() && !(stored.record.keys.back() == query)) continue;  // made by a later keyframe (below)
    if (auto why = detector.resume_correction(stored.record.revision, stored.record.keys, stored.record.T_map_sensor, stored.state)) return *why;
    summary.revision = stored.record.revision;
  }
  // A revision made by a later keyframe than its loop's (a pose-graph solve applied there) is restored with that one.
  if (stored.present && summary.revision == 0 && !stored.record.keys.empty() && stored.record.keys.back() == query) {
    const bool loop_restored = std::any_of(loops.begin(), loops.begin() + static_cast<std::ptrdiff_t>(*next),
                                           [&](const LoopDecision& d) { return d.event_id == stored.record.loop_event_id; });
    if (loop_restored) {
      if (auto why = detector.resume_correction(stored.record.revision, stored.record.keys, stored.record.T_map_sensor, stored.state)) return *why;
      summary.revision = stored.record.revision;
    }
  }
  return std::nullopt;
}

}  // namespace

ResumeSummary resume_detector(MapStore& store, LoopDetector& detector, KeyframeLoad load, bool read_only) {
  Stopwatch sw;
  ResumeSummary summary;
  // The decisions of the keyframes a stop cut off were committed, so they may have been published: read them before
  // they go, to give the same candidates the same ids when they are decided again (and not publish them twice).
  std::vector<LoopDecision> before;
  if (auto e = read_loops(store, &before)) {
    summary.error = *e;
    return summary;
  }
  const StoreResult<std::int64_t> dropped = read_only ? StoreResult<std::int64_t>{} : store.drop_undecided();
  if (!dropped.ok()) {
    summary.error = dropped.status.message;
    return summary;
  }
  summary.dropped_undecided = dropped.value;
  StoredCorrection stored;
  if (auto e = read_correction(store, &stored)) {
    summary.error = *e;
    return summary;
  }
  std::vector<LoopDecision> loops;
  if (dropped.value == 0) {
    loops = std::move(before);  // nothing cut off: the loops read above are the map's
  } else {
    if (auto e = read_loops(store, &loops)) {
      summary.error = *e;
      return summary;
    }
    std::set<std::int64_t> kept;
    for (const LoopDecision& r : loops) kept.insert(r.event_id);
    for (const LoopDecision& r : before)
      if (!kept.count(r.event_id)) {
        summary.cut_off.push_back(r);
        if (r.published) summary.cut_off_published.push_back(summary.cut_off.back());
      }
    detector.expect_decisions(summary.cut_off);
  }

  // The loop ledger: the loops revoked when the stored correction was made stay out of the graph while it is restored;
  // revocations entered since (loopd-map loops --revoke while loopd was stopped) are applied at the end.
  const StoreResult<std::vector<LoopLedgerEntry>> ledger = store.loop_ledger();
  if (!ledger.ok()) {
    summary.error = ledger.status.message;
    return summary;
  }
  const std::set<std::int64_t> revoked_then = revoked_loops(ledger.value, stored.present ? stored.record.ledger_seq : 0);

  std::size_t next_loop = 0;
  std::optional<std::string> failure;
  const StoreStatus read = store.for_each_keyframe(std::nullopt, load, [&](MapKeyframe&& k) {
    if (failure) return;
    if (load != KeyframeLoad::kFull && k.record.features) {
      auto thin = std::make_shared<KeyframeFeatures>(*k.record.features);
      thin->prepared_in_store = true;
      k.record.features = std::move(thin);
    }
    detector.restore_keyframe(k.record);
    ++summary.keyframes;
    if (k.retired) ++summary.keyframes_retired;
    summary.stored.push_back({k.record.key, k.record.utime, k.record.T_odom_sensor, k.record.scan_fingerprint});
    failure = restore_decisions(k.record.key, loops, &next_loop, stored, revoked_then, detector, summary);
  });
  if (!read.ok()) failure = read.message;
  if (!failure && next_loop != loops.size())
    failure = std::to_string(loops.size() - next_loop) + " decisions name a query keyframe the map does not hold in order";
  if (!failure && stored.present && summary.revision == 0)
    failure = "the stored correction (revision " + std::to_string(stored.record.revision) + ") names loop event " +
              std::to_string(stored.record.loop_event_id) + ", which the map does not hold";
  if (failure) {
    summary.error = store.uri() + ": cannot resume: " + *failure;
    return summary;
  }
  const std::set<std::int64_t> revoked_now = revoked_loops(ledger.value);
  summary.loops_revoked = static_cast<std::int64_t>(revoked_now.size());
  if (auto c = detector.set_revoked_loops(revoked_now, newest_seq(ledger.value))) {
    summary.ledger_corrected = true;
    summary.corrections.push_back(std::move(*c));
  }
  summary.ledger = ledger.value;
  summary.ok = true;
  summary.seconds = sw.ms() * 1e-3;
  return summary;
}

}  // namespace loopd
