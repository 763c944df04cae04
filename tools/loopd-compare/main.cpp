// loopd-compare: did two loopd runs make the same decisions? Compares the loop events and the last corrected
// trajectory of two loopd output logs (timing fields and publication utimes ignored).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>

#include "compare_runs.hpp"
#include "run_log.hpp"
#include "tool_output.hpp"

using namespace loopd::tools;

namespace {

constexpr std::size_t kListedPairs = 5;  ///< pairs listed in the table (JSON lists up to kJsonPairs)
constexpr std::size_t kJsonPairs = 20;
constexpr int kExitIdentical = 0, kExitDifferent = 1, kExitBadInput = 2;

std::string sci(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

/// A keyframe as "17" in session 0 (single-session runs read as before), else "session/id".
std::string key_text(const loopd::KeyframeKey& k) { return k.session == 0 ? std::to_string(k.index) : loopd::to_string(k); }

std::string pair_text(const LoopPair& p) { return key_text(p.first) + "->" + key_text(p.second); }

/// [query id, match id] when both are of session 0, else [query session, query id, match session, match id].
nlohmann::json pair_json(const LoopPair& p) {
  if (p.first.session == 0 && p.second.session == 0) return {p.first.index, p.second.index};
  return {p.first.session, p.first.index, p.second.session, p.second.index};
}

std::string pairs_text(const std::vector<LoopPair>& pairs) {
  std::string s;
  for (std::size_t i = 0; i < pairs.size() && i < kListedPairs; ++i) s += (i ? ", " : "") + pair_text(pairs[i]);
  if (pairs.size() > kListedPairs) s += ", ... (" + std::to_string(pairs.size() - kListedPairs) + " more)";
  return s;
}

nlohmann::json pairs_json(const std::vector<LoopPair>& pairs) {
  nlohmann::json j = nlohmann::json::array();
  for (std::size_t i = 0; i < pairs.size() && i < kJsonPairs; ++i) j.push_back(pair_json(pairs[i]));
  return j;
}

std::string count(std::int64_t n) { return std::to_string(n); }

std::string table_text(const RunComparison& c) {
  const DecisionComparison& l = c.loops;
  const TrajectoryComparison& t = c.trajectory;
  Table table({"", "A", "B", "both / max diff"});
  table.add({"loop events", count(l.events_a), count(l.events_b), ""});
  table.add({"accepted pairs", count(l.accepted_a), count(l.accepted_b), count(l.accepted_both)});
  table.add({"accepted only in one", count(static_cast<std::int64_t>(l.accepted_only_a.size())),
             count(static_cast<std::int64_t>(l.accepted_only_b.size())), ""});
  table.add({"pairs decided only in one", count(static_cast<std::int64_t>(l.decided_only_a.size())),
             count(static_cast<std::int64_t>(l.decided_only_b.size())), ""});
  table.add({"decisions that differ", "", "", count(static_cast<std::int64_t>(l.decisions_differ.size()))});
  table.add({"loop T_match_query translation [m]", "", "", sci(l.max_loop_translation_diff_m)});
  table.add({"loop T_match_query rotation [deg]", "", "", sci(l.max_loop_rotation_diff_deg)});
  table.add({"trajectory revisions", count(t.revisions_a), count(t.revisions_b), ""});
  table.add({"last revision", count(t.last_revision_a), count(t.last_revision_b), ""});
  table.add({"keyframes", count(t.keyframes_a), count(t.keyframes_b), count(t.keyframes_both)});
  table.add({"same keyframe ids", "", "", t.same_keyframe_ids ? "yes" : "no"});
  table.add({"keyframe position [m]", "", "", sci(t.max_pose_translation_diff_m)});
  table.add({"keyframe rotation [deg]", "", "", sci(t.max_pose_rotation_diff_deg)});
  return table.str();
}

std::string details_text(const DecisionComparison& l) {
  std::string s;
  if (!l.accepted_only_a.empty()) s += "accepted only in A: " + pairs_text(l.accepted_only_a) + "\n";
  if (!l.accepted_only_b.empty()) s += "accepted only in B: " + pairs_text(l.accepted_only_b) + "\n";
  for (std::size_t i = 0; i < l.decisions_differ.size() && i < kListedPairs; ++i) {
    const DecisionDifference& d = l.decisions_differ[i];
    s += "decision differs " + pair_text(d.pair) + ": A " + d.decisions_a + " | B " + d.decisions_b + "\n";
  }
  if (l.decisions_differ.size() > kListedPairs)
    s += "... " + std::to_string(l.decisions_differ.size() - kListedPairs) + " more differing decisions\n";
  return s;
}

nlohmann::json result_json(const RunComparison& c, const RunLog& a, const RunLog& b, const CompareTolerances& tol) {
  const DecisionComparison& l = c.loops;
  const TrajectoryComparison& t = c.trajectory;
  nlohmann::json differ = nlohmann::json::array();
  for (std::size_t i = 0; i < l.decisions_differ.size() && i < kJsonPairs; ++i) {
    const DecisionDifference& d = l.decisions_differ[i];
    differ.push_back({{"query_id", d.pair.first.index},
                      {"match_id", d.pair.second.index},
                      {"query_session", d.pair.first.session},
                      {"match_session", d.pair.second.session},
                      {"a", d.decisions_a},
                      {"b", d.decisions_b}});
  }
  return {{"events_a", l.events_a},
          {"events_b", l.events_b},
          {"accepted_a", l.accepted_a},
          {"accepted_b", l.accepted_b},
          {"accepted_both", l.accepted_both},
          {"accepted_only_a", l.accepted_only_a.size()},
          {"accepted_only_b", l.accepted_only_b.size()},
          {"accepted_only_a_pairs", pairs_json(l.accepted_only_a)},
          {"accepted_only_b_pairs", pairs_json(l.accepted_only_b)},
          {"decided_only_a", l.decided_only_a.size()},
          {"decided_only_b", l.decided_only_b.size()},
          {"decisions_differ", l.decisions_differ.size()},
          {"decisions_differ_first", differ},
          {"max_loop_translation_diff_m", l.max_loop_translation_diff_m},
          {"max_loop_rotation_diff_deg", l.max_loop_rotation_diff_deg},
          {"trajectory_revisions_a", t.revisions_a},
          {"trajectory_revisions_b", t.revisions_b},
          {"trajectory_last_revision_a", t.last_revision_a},
          {"trajectory_last_revision_b", t.last_revision_b},
          {"trajectory_keyframes_a", t.keyframes_a},
          {"trajectory_keyframes_b", t.keyframes_b},
          {"trajectory_keyframes_both", t.keyframes_both},
          {"same_keyframe_ids", t.same_keyframe_ids},
          {"max_pose_translation_diff_m", t.max_pose_translation_diff_m},
          {"max_pose_rotation_diff_deg", t.max_pose_rotation_diff_deg},
          {"malformed_a", a.malformed},
          {"malformed_b", b.malformed},
          {"repeated_events_a", a.repeated_events},
          {"repeated_events_b", b.repeated_events},
          {"problems_a", a.problems},
          {"problems_b", b.problems},
          {"tolerance_m", tol.translation_m},
          {"tolerance_deg", tol.rotation_deg},
          {"identical", c.identical}};
}

/// Damage a log reader skipped, on stderr: the comparison still runs on what could be read.
void report_damage(const std::string& label, const RunLog& run) {
  if (!run.problems.empty()) std::cerr << "loopd-compare: warning: " << label << " " << run.problems << "\n";
  if (run.repeated_events > 0)
    std::cerr << "loopd-compare: note: " << label << " " << run.repeated_events
              << " loop events repeat an earlier event_id: the later ones are compared\n";
  if (run.malformed > 0)
    std::cerr << "loopd-compare: warning: " << label << " " << run.malformed
              << " loop/trajectory events did not decode, first: " << run.first_malformed << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loopd-compare: do two loopd output logs hold the same loop decisions and corrected trajectory?"};
  std::string path_a, path_b;
  CompareTolerances tol;
  CompareChannels ch;
  bool json = false;
  app.add_option("A", path_a, "first loopd output log (loopd --output, or lcm-logger of a live run)")->required();
  app.add_option("B", path_b, "second loopd output log")->required();
  app.add_option("--tolerance-m", tol.translation_m, "[m] largest translation difference that counts as identical")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--tolerance-deg", tol.rotation_deg, "[deg] largest rotation difference that counts as identical")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--loop-channel", ch.loop_event)->capture_default_str();
  app.add_option("--trajectory-channel", ch.trajectory)->capture_default_str();
  app.add_flag("--json", json, "print one JSON object as the last stdout line");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? kExitIdentical : kExitBadInput;
  }

  RunLog a, b;
  std::string error;
  if (!read_run_log(path_a, ch, &a, &error) || !read_run_log(path_b, ch, &b, &error)) {
    std::cerr << "loopd-compare: " << error << "\n";
    return kExitBadInput;
  }
  report_damage("A", a);
  report_damage("B", b);
  const RunComparison c = compare_runs(a, b, tol);
  std::cout << "A: " << path_a << "\nB: " << path_b << "\n" << table_text(c) << details_text(c.loops);
  std::cout << (c.identical ? "IDENTICAL" : "DIFFERENT") << " (tolerances " << sci(tol.translation_m) << " m, " << sci(tol.rotation_deg) << " deg)\n";
  if (json) print_json_line(result_json(c, a, b, tol));
  return c.identical ? kExitIdentical : kExitDifferent;
}
