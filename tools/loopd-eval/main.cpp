// loopd-eval: judges loopd's output log against a drive's ground truth (Vlaminck 2019, 5.3 and 5.4).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>

#include "eval_log.hpp"
#include "map_eval.hpp"
#include "loopd/eval/evaluation.hpp"
#include "loopd/base/trajectory_io.hpp"
#include "plots.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;
using namespace loopd::tools;

namespace {

constexpr const char* kSessionsHelp = R"(Sessions (a later drive on the same map, or a drive's part after an odometry reset; ids from the
trajectory's keyframe_sessions, the first = the map):
  sessions                      distinct sessions in the last trajectory revision (keyframes and session list)
  sessions_aligned / _unaligned sessions after the first that are / are not anchored (trajectory_t.sessions[].anchored)
  inter_session_loops_accepted  accepted loop pairs with query_session != match_session
  inter_session_loops_correct   ... of them within --closure-translation / --closure-rotation of ground truth
  session_alignment_error_m/deg worst over the sessions after the first of: the median, over the session's keyframes q
                                from its first accepted inter-session loop on that lie within --mapped-radius (ground
                                truth) of an earlier session's keyframe, of the error of T_map_m^-1 T_map_q against
                                T_world_m^-1 T_world_q (m = the nearest such earlier keyframe); null when no session has one
  session_alignment_distance_m  worst over those sessions of the ground-truth path driven within --mapped-radius of an
                                earlier session's keyframe before the session's first accepted inter-session loop)";

/// @brief One --drive log: its ground-truth time span and scans.
struct DriveSpan {
  std::int64_t first_utime = 0, last_utime = 0;  ///< [us]
  std::int64_t scans = 0;
};

nlohmann::json timing_json(const TimingStats& t) { return {{"median", t.median}, {"p95", t.p95}, {"max", t.max}, {"count", t.count}}; }

bool export_trajectories(const std::string& dir, const EvalReport& rep, bool kitti, std::string* error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  const std::string d = dir + "/";
  std::vector<Eigen::Isometry3d> gt_all;
  const TrajectoryFormat format = kitti ? TrajectoryFormat::kKitti : TrajectoryFormat::kTum;
  const std::string suffix = kitti ? ".kitti.txt" : ".tum";
  std::vector<double> seconds;  // TUM stamps [s]
  for (const std::int64_t utime : rep.keyframe_utimes) seconds.push_back(static_cast<double>(utime) * 1e-6);
  for (const auto& [name, poses] :
       {std::pair{"ground_truth", &rep.gt_keyframes}, std::pair{"odometry", &rep.before_keyframes}, std::pair{"corrected", &rep.after_keyframes}}) {
    const std::size_t n = std::min(poses->size(), kitti ? poses->size() : seconds.size());  // TUM: a line per stamp
    const std::vector<Eigen::Isometry3d> head(poses->begin(), poses->begin() + static_cast<std::ptrdiff_t>(n));
    if (auto e = write_trajectory(d + name + suffix, head, seconds, format)) {
      *error = *e;
      return false;
    }
  }
  return true;
}

/// @brief One CSV line per accepted loop with ground truth at both ends: where it lies and how far its T_match_query is
///        from the truth (the lines behind loop_translation_error_* and loop_rotation_error_*).
bool export_loop_errors(const std::string& path, const EvalInput& input, const EvalReport& rep, std::string* error) {
  std::ofstream out(path);
  if (!out) {
    *error = "cannot write " + path;
    return false;
  }
  out << "event_id,query_utime,match_utime,query_keyframe,match_keyframe,frame_gap,gt_distance_m,translation_error_m,rotation_error_deg,correct\n";
  out.precision(9);
  for (const LoopCheck& c : rep.checks) {
    const LoopDecision& l = input.loops[c.loop];
    if (!c.has_ground_truth || l.status != LoopStatus::kAccepted) continue;
    out << l.event_id << ',' << l.query_utime << ',' << l.match_utime << ',' << c.query_keyframe << ',' << c.match_keyframe << ',' << c.frame_gap
        << ',' << c.gt_distance << ',' << c.translation_error << ',' << c.rotation_error_deg << ',' << (c.correct ? 1 : 0) << '\n';
  }
  out.flush();
  if (!out) *error = "writing " + path + " failed";
  return static_cast<bool>(out);
}

/// @brief Reads every drive log (in the order given) and every results log into `input`; false after printing why.
bool read_logs(const std::vector<std::string>& drives, const std::vector<std::string>& results, const EvalChannels& ch, bool quiet, EvalInput* input,
               std::vector<DriveSpan>* spans, LogReadStats* drive_stats, LogReadStats* result_stats) {
  std::string error;
  std::vector<EvalInput> drive_inputs;
  for (std::size_t i = 0; i < drives.size(); ++i) {
    Progress bar(drives.size() > 1 ? "reading drive " + std::to_string(i + 1) : "reading drive  ", 100, !quiet);
    auto cb = [&](std::int64_t done, std::int64_t total) { bar.update(total > 0 ? done * 100 / total : 0); };
    EvalInput d;
    LogReadStats st;
    if (!read_drive_log(drives[i], ch, &d, &st, cb, &error)) {
      std::cerr << "\nloopd-eval: " << error << "\n";
      return false;
    }
    bar.finish();
    spans->push_back({d.ground_truth.front().utime, d.ground_truth.back().utime, st.scans});
    for (const auto& p : d.ground_truth) {
      spans->back().first_utime = std::min(spans->back().first_utime, p.utime);
      spans->back().last_utime = std::max(spans->back().last_utime, p.utime);
    }
    drive_stats->add(st);
    drive_inputs.push_back(std::move(d));
  }
  merge_drives(std::move(drive_inputs), input);
  for (std::size_t i = 0; i < results.size(); ++i) {
    Progress bar(results.size() > 1 ? "reading results " + std::to_string(i + 1) : "reading results", 100, !quiet);
    auto cb = [&](std::int64_t done, std::int64_t total) { bar.update(total > 0 ? done * 100 / total : 0); };
    EvalInput part;
    LogReadStats st;
    if (!read_results_log(results[i], ch, &part, &st, cb, &error)) {
      std::cerr << "\nloopd-eval: " << error << "\n";
      return false;
    }
    bar.finish();
    merge_results(std::move(part), st, input, result_stats);
  }
  return true;
}

/// @brief 1-based --drive whose ground truth spans `utime`, or 0.
std::size_t drive_of(const std::vector<DriveSpan>& spans, std::int64_t utime) {
  for (std::size_t i = 0; i < spans.size(); ++i)
    if (utime >= spans[i].first_utime && utime <= spans[i].last_utime) return i + 1;
  return 0;
}

std::string opt_fmt(const std::optional<double>& v, int precision, const char* none = "-") { return v ? fmt(*v, precision) : none; }
nlohmann::json opt_json(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); }

/// @brief The "sessions" block: one row per loopd session (printed when there is more than one).
void print_sessions(const SessionMetrics& sm, const std::vector<DriveSpan>& spans) {
  if (sm.sessions <= 1) return;
  Table t({"session", "drive", "keyframes", "anchored", "alignment error median [m / deg] (keyframes)", "distance to alignment [m]"});
  for (const SessionStats& s : sm.per_session) {
    const std::size_t drive = drive_of(spans, s.first_utime);
    const std::string err = s.first ? "-"
                                    : opt_fmt(s.alignment_error_m, 3, "null") + " / " + opt_fmt(s.alignment_error_deg, 2, "null") + " (" +
                                          std::to_string(s.alignment_samples) + ")";
    std::string dist = "-";
    if (!s.first)
      dist = s.distance_to_alignment_m ? fmt(*s.distance_to_alignment_m, 1) : "never (" + fmt(s.mapped_distance_m, 1) + " in the mapped area)";
    t.add({std::to_string(s.session), drive > 0 ? std::to_string(drive) : "?", std::to_string(s.keyframes),
           s.first ? "map" : (s.anchored ? "yes" : "no"), err, dist});
  }
  std::cout << t.str() << "sessions: " << sm.sessions << ", aligned " << sm.sessions_aligned << ", unaligned " << sm.sessions_unaligned
            << "; inter-session loops accepted / correct: " << sm.inter_session_loops_accepted << " / " << sm.inter_session_loops_correct
            << "; worst alignment error " << opt_fmt(sm.alignment_error_m, 3, "null") << " m / " << opt_fmt(sm.alignment_error_deg, 2, "null")
            << " deg, worst distance to alignment " << opt_fmt(sm.alignment_distance_m, 1, "null") << " m\n\n";
}

/// @brief The multi-session JSON keys (beside the single-drive ones).
void add_session_json(const SessionMetrics& sm, const std::vector<DriveSpan>& spans, nlohmann::json& j) {
  j["sessions"] = sm.sessions;
  j["sessions_aligned"] = sm.sessions_aligned;
  j["sessions_unaligned"] = sm.sessions_unaligned;
  j["inter_session_loops_accepted"] = sm.inter_session_loops_accepted;
  j["inter_session_loops_correct"] = sm.inter_session_loops_correct;
  j["session_alignment_error_m"] = opt_json(sm.alignment_error_m);
  j["session_alignment_error_deg"] = opt_json(sm.alignment_error_deg);
  j["session_alignment_distance_m"] = opt_json(sm.alignment_distance_m);
  nlohmann::json per = nlohmann::json::array();
  for (const SessionStats& s : sm.per_session)
    per.push_back({{"session", s.session},
                   {"drive", drive_of(spans, s.first_utime)},
                   {"keyframes", s.keyframes},
                   {"first", s.first},
                   {"anchored", s.anchored},
                   {"alignment_error_m", opt_json(s.alignment_error_m)},
                   {"alignment_error_deg", opt_json(s.alignment_error_deg)},
                   {"alignment_samples", s.alignment_samples},
                   {"distance_to_alignment_m", opt_json(s.distance_to_alignment_m)},
                   {"mapped_distance_m", s.mapped_distance_m}});
  j["session_stats"] = per;
}

/// @brief The --json object: the single-drive keys and the session keys.
nlohmann::json report_json(const EvalReport& rep, const LogReadStats& drive_stats, const LogReadStats& result_stats,
                           const std::vector<DriveSpan>& spans, const std::vector<std::string>& pictures, const std::vector<std::string>& warnings) {
  const auto& d = rep.detection;
  const auto& c = rep.closure;
  nlohmann::json j;
  j["precision"] = d.precision;
  j["recall"] = d.recall;
  j["f1"] = d.f1;
  j["true_positives"] = d.true_positives;
  j["false_positives"] = d.false_positives;
  j["false_negatives"] = d.false_negatives;
  j["gt_queries"] = d.gt_queries;
  j["gt_pairs"] = d.gt_pairs;
  j["max_recall"] = d.max_recall;
  j["precision_at_max_recall"] = d.precision_at_max_recall;
  j["f1_max"] = d.f1_max;
  j["f1_max_threshold"] = d.f1_max_threshold;
  j["accepted"] = c.accepted;
  j["correct"] = c.correct;
  j["closure_precision"] = c.precision;
  j["closure_recall"] = c.recall;
  j["closure_recall_correct"] = c.recall_correct;
  j["stretches"] = c.stretches;
  j["stretches_closed"] = c.stretches_closed;
  j["stretches_closed_share"] = c.stretches_closed_share;
  j["stretch_list"] = nlohmann::json::array();
  for (const auto& s : c.stretch_list) j["stretch_list"].push_back({{"first_keyframe", s.first}, {"last_keyframe", s.last}, {"closed", s.closed}});
  j["mean_error_before"] = rep.error_before.mean;
  j["mean_error_after"] = rep.error_after.mean;
  j["median_error_before"] = rep.error_before.median;
  j["median_error_after"] = rep.error_after.median;
  j["loop_translation_error_median"] = rep.loop_translation_error.median;
  j["loop_translation_error_p95"] = rep.loop_translation_error.p95;
  j["loop_translation_error_max"] = rep.loop_translation_error.max;
  j["loop_rotation_error_median_deg"] = rep.loop_rotation_error_deg.median;
  j["loop_rotation_error_p95_deg"] = rep.loop_rotation_error_deg.p95;
  j["loop_rotation_error_max_deg"] = rep.loop_rotation_error_deg.max;
  j["ate_before"] = rep.ate_before;
  j["ate_after"] = rep.ate_after;
  j["has_corrected"] = rep.has_corrected;
  j["keyframes"] = rep.keyframe_utimes.size();
  j["scans"] = drive_stats.scans;
  j["loop_events"] = result_stats.loop_events;
  j["repeated_loop_events"] = result_stats.repeated_events;
  j["trajectory_revision"] = result_stats.trajectory_revision;
  j["timings"] = {{"descriptor", timing_json(rep.ms_descriptor)},
                  {"fourpcs", timing_json(rep.ms_fourpcs)},
                  {"gicp", timing_json(rep.ms_gicp)},
                  {"hungarian", timing_json(rep.ms_hungarian)},
                  {"total", timing_json(rep.ms_total)}};
  nlohmann::json pr = nlohmann::json::array();
  for (const auto& p : d.pr_curve) pr.push_back({p.threshold, p.precision, p.recall});
  j["pr_curve"] = pr;  // [threshold, precision, recall]
  add_session_json(rep.sessions, spans, j);
  j["pictures"] = pictures;
  j["warnings"] = warnings;
  return j;
}

/// @brief The command line.
struct Args {
  std::vector<std::string> drives, results;
  std::string plots_dir, tum_dir, kitti_dir, loops_csv;
  bool json = false, quiet = false;
  EvalConfig config;
  EvalChannels ch;
  MapEvalOptions map_options;
};

void add_options(CLI::App& app, Args& a) {
  app.add_option("--drive", a.drives,
                 "drive log (lcm-logger) with LIDAR_SCAN, ODOMETRY_POSE, GROUND_TRUTH_POSE; once per session's drive, in order "
                 "(keyframes find their ground truth by utime in any of them)")
      ->required()
      ->take_all()
      ->check(CLI::ExistingFile);
  app.add_option("--results", a.results,
                 "loopd's output log with LOOP_EVENT and CORRECTED_TRAJECTORY; more than once: loop events of all, the trajectory of "
                 "the log whose last revision holds the most keyframes")
      ->required()
      ->take_all()
      ->check(CLI::ExistingFile);
  app.add_option("--mapped-radius", a.config.sessions.mapped_radius,
                 "[m] sessions: a place of a later session is in the mapped area within this of an earlier session's keyframe")
      ->capture_default_str();
  app.footer(kSessionsHelp);
  app.add_flag("--json", a.json, "print one JSON object as the last stdout line");
  app.add_option("--plots", a.plots_dir, "write trajectories and PR-curve pictures (PNG + SVG) into this folder");
  app.add_option("--export-tum", a.tum_dir, "write ground truth, odometry and corrected keyframe trajectories (TUM)");
  app.add_option("--export-kitti", a.kitti_dir, "same in KITTI format (12 numbers a line)");
  app.add_option("--export-loops", a.loops_csv, "write one CSV line per accepted loop: its keyframes, frame gap and error against ground truth");
  app.add_option("--loop-distance", a.config.ground_truth.max_distance, "[m] ground-truth loop: closer than this")->capture_default_str();
  app.add_option("--min-frame-gap", a.config.ground_truth.min_frame_gap, "ground-truth loop: more than this many scans apart")->capture_default_str();
  app.add_flag("--planar", a.config.ground_truth.planar, "measure loop distances in the ground plane (x, y), not 3D");
  app.add_option("--closure-translation", a.config.closure_max_translation,
                 "[m] accepted loop correct when T_match_query is within this of ground truth")
      ->capture_default_str();
  app.add_option("--closure-rotation", a.config.closure_max_rotation_deg, "[deg] ... and within this rotation")->capture_default_str();
  app.add_option("--scan-channel", a.ch.scan)->capture_default_str();
  app.add_option("--odometry-channel", a.ch.odometry)->capture_default_str();
  app.add_option("--ground-truth-channel", a.ch.ground_truth)->capture_default_str();
  app.add_option("--loop-channel", a.ch.loop_event)->capture_default_str();
  app.add_option("--trajectory-channel", a.ch.trajectory)->capture_default_str();
  app.add_flag("--quiet", a.quiet, "no progress bar");
  add_map_options(app, &a.map_options);
}

/// @brief The tables: what was read, loop detection, loop closure, pose error, sessions, the 3D map, timing.
void print_tables(const Args& a, const EvalReport& rep, const LogReadStats& drive_stats, const LogReadStats& result_stats,
                  const std::vector<DriveSpan>& spans, const MapEvalReport& map_report) {
  const std::vector<std::string>& drives = a.drives;
  const EvalConfig& config = a.config;
  const auto& d = rep.detection;
  const auto& c = rep.closure;
  if (spans.size() > 1)
    for (std::size_t i = 0; i < spans.size(); ++i) std::cout << "drive " << i + 1 << ": " << drives[i] << ", " << spans[i].scans << " scans\n";
  std::cout << "drive:   " << drive_stats.scans << " scans, " << drive_stats.ground_truth << " ground-truth poses, " << drive_stats.odometry
            << " odometry poses\n"
            << "results: " << result_stats.loop_events << " loop events, " << result_stats.trajectories << " trajectory revisions (using revision "
            << result_stats.trajectory_revision << ")\n"
            << "keyframes evaluated: " << rep.keyframe_utimes.size() << "; ground-truth loops (" << (config.ground_truth.planar ? "planar" : "3D")
            << " < " << fmt(config.ground_truth.max_distance, 2) << " m, > " << config.ground_truth.min_frame_gap << " frames): " << d.gt_pairs
            << " pairs, " << d.gt_queries << " query keyframes, " << c.stretches << " revisited stretches\n\n";
  Table det({"loop detection (accepted)", "value"});
  det.add({"true positives", std::to_string(d.true_positives)});
  det.add({"false positives", std::to_string(d.false_positives)});
  det.add({"false negatives (gt queries missed)", std::to_string(d.false_negatives)});
  det.add({"precision", fmt(d.precision)});
  det.add({"recall", fmt(d.recall)});
  det.add({"F1", fmt(d.f1)});
  det.add({"PR curve points (descriptor)", std::to_string(d.pr_curve.size())});
  det.add({"max recall / precision there", fmt(d.max_recall) + " / " + fmt(d.precision_at_max_recall)});
  det.add({"F1 max (at descriptor distance)", fmt(d.f1_max) + " (" + fmt(d.f1_max_threshold, 4) + ")"});
  std::cout << det.str() << "\n";
  Table clo({"loop closure", "value"});
  clo.add({"accepted / correct", std::to_string(c.accepted) + " / " + std::to_string(c.correct)});
  clo.add({"precision (correct / accepted)", fmt(c.precision)});
  clo.add({"recall (gt queries with accepted loop)", fmt(c.recall)});
  clo.add({"recall (correct loops only)", fmt(c.recall_correct)});
  clo.add({"revisited stretches closed",
           std::to_string(c.stretches_closed) + " / " + std::to_string(c.stretches) + " (" + fmt(100.0 * c.stretches_closed_share, 1) + " %)"});
  const ErrorStats& lt = rep.loop_translation_error;
  const ErrorStats& lr = rep.loop_rotation_error_deg;
  clo.add({"loop transform error vs gt, median", fmt(lt.median, 4) + " m / " + fmt(lr.median, 3) + " deg"});
  clo.add({"loop transform error vs gt, p95 / max",
           fmt(lt.p95, 4) + " m / " + fmt(lr.p95, 3) + " deg, " + fmt(lt.max, 3) + " m / " + fmt(lr.max, 2) + " deg"});
  std::cout << clo.str() << "\n";
  Table err({"pose error [m]", "before (odometry)", "after (corrected)"});
  err.add({"mean, closest gt pose", fmt(rep.error_before.mean), fmt(rep.error_after.mean)});
  err.add({"median, closest gt pose", fmt(rep.error_before.median), fmt(rep.error_after.median)});
  err.add({"max, closest gt pose", fmt(rep.error_before.max), fmt(rep.error_after.max)});
  err.add({"ATE RMSE (SE(3) aligned)", fmt(rep.ate_before), fmt(rep.ate_after)});
  std::cout << err.str() << (rep.has_corrected ? "" : "(no corrected trajectory: 'after' is odometry)\n") << "\n";
  print_sessions(rep.sessions, spans);
  print_map_eval(map_report);
  Table tim({"stage timing [ms]", "median", "p95", "max", "count"});
  const std::pair<const char*, const TimingStats*> stages[] = {{"descriptor", &rep.ms_descriptor},
                                                               {"fourpcs", &rep.ms_fourpcs},
                                                               {"gicp", &rep.ms_gicp},
                                                               {"hungarian", &rep.ms_hungarian},
                                                               {"total", &rep.ms_total}};
  for (const auto& [name, t] : stages) tim.add({name, fmt(t->median, 1), fmt(t->p95, 1), fmt(t->max, 1), std::to_string(t->count)});
  std::cout << tim.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loopd-eval: loop detection, loop closure and pose error of loopd's output against ground truth"};
  Args args;
  add_options(app, args);
  const std::vector<std::string>& drives = args.drives;
  const EvalConfig& config = args.config;
  const EvalChannels& ch = args.ch;
  const MapEvalOptions& map_options = args.map_options;
  const bool &quiet = args.quiet, &json = args.json;  // references: filled by the parse below
  const std::string &plots_dir = args.plots_dir, &tum_dir = args.tum_dir, &kitti_dir = args.kitti_dir, &loops_csv = args.loops_csv;
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  if (auto e = config.validate(); e || (e = map_options.validate())) {
    std::cerr << "loopd-eval: " << *e << "\n";
    return 2;
  }

  EvalInput input;
  LogReadStats drive_stats, result_stats;
  std::vector<DriveSpan> spans;
  if (!read_logs(drives, args.results, ch, quiet, &input, &spans, &drive_stats, &result_stats)) return tools::kExitUsage;
  const EvalReport rep = evaluate(input, config);
  if (!rep.ok) {  // the logs hold nothing to evaluate (no ground truth, no keyframes): bad input
    std::cerr << "loopd-eval: " << rep.error << "\n";
    return tools::kExitUsage;
  }
  MapEvalReport map_report;
  std::string map_error;
  if (!run_map_eval(map_options, drives, ch, input, quiet, &map_report, &map_error)) {
    std::cerr << "loopd-eval: " << map_error << "\n";
    return tools::kExitUsage;
  }
  std::vector<std::string> warnings = rep.warnings;
  warnings.insert(warnings.end(), map_report.warnings.begin(), map_report.warnings.end());
  if (result_stats.loop_events == 0) warnings.push_back("the results log holds no loop events");
  if (result_stats.repeated_events > 0)
    warnings.push_back(std::to_string(result_stats.repeated_events) + " loop events repeat an earlier event_id: the later ones are used");
  if (drive_stats.malformed + result_stats.malformed > 0)
    warnings.push_back(std::to_string(drive_stats.malformed + result_stats.malformed) + " undecodable events skipped");

  std::vector<std::string> pictures;
  if (!plots_dir.empty()) {
    std::string perr;
    pictures = write_plots(plots_dir, input, rep, &perr);
    if (!perr.empty()) warnings.push_back(perr);
  }
  for (const auto& [dir, kitti] : {std::make_pair(tum_dir, false), std::make_pair(kitti_dir, true)}) {
    if (dir.empty()) continue;
    std::string eerr;
    if (!export_trajectories(dir, rep, kitti, &eerr)) warnings.push_back("export failed: " + eerr);
  }
  if (std::string lerr; !loops_csv.empty() && !export_loop_errors(loops_csv, input, rep, &lerr)) warnings.push_back("export failed: " + lerr);

  print_tables(args, rep, drive_stats, result_stats, spans, map_report);
  for (const auto& p : pictures) std::cout << "picture: " << p << "\n";
  for (const auto& w : warnings) std::cout << "warning: " << w << "\n";

  if (!json) return 0;
  nlohmann::json j = report_json(rep, drive_stats, result_stats, spans, pictures, warnings);
  add_map_json(map_report, j);
  print_json_line(j);
  return 0;
}
