// loopd-eval: judges loopd's output log against a drive's ground truth (Vlaminck 2019, 5.3 and 5.4).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>

#include "eval_log.hpp"
#include "loopd/eval/evaluation.hpp"
#include "loopd/core/trajectory_io.hpp"
#include "plots.hpp"
#include "tool_output.hpp"

using namespace loopd;
using namespace loopd::tools;

namespace {

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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loopd-eval: loop detection, loop closure and pose error of loopd's output against ground truth"};
  std::string drive, results, plots_dir, tum_dir, kitti_dir;
  bool json = false, quiet = false;
  EvalConfig config;
  EvalChannels ch;
  app.add_option("--drive", drive, "drive log (lcm-logger) with LIDAR_SCAN, ODOMETRY_POSE, GROUND_TRUTH_POSE")->required()->check(CLI::ExistingFile);
  app.add_option("--results", results, "loopd's output log with LOOP_EVENT and CORRECTED_TRAJECTORY")->required()->check(CLI::ExistingFile);
  app.add_flag("--json", json, "print one JSON object as the last stdout line");
  app.add_option("--plots", plots_dir, "write trajectories and PR-curve pictures (PNG + SVG) into this folder");
  app.add_option("--export-tum", tum_dir, "write ground truth, odometry and corrected keyframe trajectories (TUM)");
  app.add_option("--export-kitti", kitti_dir, "same in KITTI format (12 numbers a line)");
  app.add_option("--loop-distance", config.ground_truth.max_distance, "[m] ground-truth loop: closer than this")->capture_default_str();
  app.add_option("--min-frame-gap", config.ground_truth.min_frame_gap, "ground-truth loop: more than this many scans apart")->capture_default_str();
  app.add_flag("--planar", config.ground_truth.planar, "measure loop distances in the ground plane (x, y), not 3D");
  app.add_option("--closure-translation", config.closure_max_translation,
                 "[m] accepted loop correct when T_match_query is within this of ground truth")
      ->capture_default_str();
  app.add_option("--closure-rotation", config.closure_max_rotation_deg, "[deg] ... and within this rotation")->capture_default_str();
  app.add_option("--scan-channel", ch.scan)->capture_default_str();
  app.add_option("--odometry-channel", ch.odometry)->capture_default_str();
  app.add_option("--ground-truth-channel", ch.ground_truth)->capture_default_str();
  app.add_option("--loop-channel", ch.loop_event)->capture_default_str();
  app.add_option("--trajectory-channel", ch.trajectory)->capture_default_str();
  app.add_flag("--quiet", quiet, "no progress bar");
  CLI11_PARSE(app, argc, argv);
  if (auto e = config.validate()) {
    std::cerr << "loopd-eval: " << *e << "\n";
    return 2;
  }

  EvalInput input;
  LogReadStats drive_stats, result_stats;
  std::string error;
  {
    Progress bar("reading drive  ", 100, !quiet);
    auto cb = [&](std::int64_t done, std::int64_t total) { bar.update(total > 0 ? done * 100 / total : 0); };
    if (!read_drive_log(drive, ch, &input, &drive_stats, cb, &error)) {
      std::cerr << "\nloopd-eval: " << error << "\n";
      return 1;
    }
    bar.finish();
  }
  {
    Progress bar("reading results", 100, !quiet);
    auto cb = [&](std::int64_t done, std::int64_t total) { bar.update(total > 0 ? done * 100 / total : 0); };
    if (!read_results_log(results, ch, &input, &result_stats, cb, &error)) {
      std::cerr << "\nloopd-eval: " << error << "\n";
      return 1;
    }
    bar.finish();
  }
  const EvalReport rep = evaluate(input, config);
  if (!rep.ok) {
    std::cerr << "loopd-eval: " << rep.error << "\n";
    return 1;
  }
  std::vector<std::string> warnings = rep.warnings;
  if (result_stats.loop_events == 0) warnings.push_back("the results log holds no loop events");
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

  const auto& d = rep.detection;
  const auto& c = rep.closure;
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
  Table tim({"stage timing [ms]", "median", "p95", "max", "count"});
  const std::pair<const char*, const TimingStats*> stages[] = {{"descriptor", &rep.ms_descriptor},
                                                               {"fourpcs", &rep.ms_fourpcs},
                                                               {"gicp", &rep.ms_gicp},
                                                               {"hungarian", &rep.ms_hungarian},
                                                               {"total", &rep.ms_total}};
  for (const auto& [name, t] : stages) tim.add({name, fmt(t->median, 1), fmt(t->p95, 1), fmt(t->max, 1), std::to_string(t->count)});
  std::cout << tim.str();
  for (const auto& p : pictures) std::cout << "picture: " << p << "\n";
  for (const auto& w : warnings) std::cout << "warning: " << w << "\n";

  if (json) {
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
    j["trajectory_revision"] = result_stats.trajectory_revision;
    j["timings"] = {{"descriptor", timing_json(rep.ms_descriptor)},
                    {"fourpcs", timing_json(rep.ms_fourpcs)},
                    {"gicp", timing_json(rep.ms_gicp)},
                    {"hungarian", timing_json(rep.ms_hungarian)},
                    {"total", timing_json(rep.ms_total)}};
    nlohmann::json pr = nlohmann::json::array();
    for (const auto& p : d.pr_curve) pr.push_back({p.threshold, p.precision, p.recall});
    j["pr_curve"] = pr;  // [threshold, precision, recall]
    j["pictures"] = pictures;
    j["warnings"] = warnings;
    print_json_line(j);
  }
  return 0;
}
