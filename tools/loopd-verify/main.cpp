// loopd-verify QUERY MATCH: is MATCH the same place as QUERY? 4PCS -> GICP -> degeneracy -> Hungarian (Vlaminck 2019 Sec. 4.3).
#include <CLI/CLI.hpp>
#include <iostream>
#include <optional>

#include "loopd/runtime/daemon_config.hpp"
#include "loopd/base/lidar_model.hpp"
#include "loopd/base/scene_scale.hpp"
#include "loopd/base/sensor_estimate.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/pipeline/loop_detector.hpp"
#include "loopd/pipeline/prepare_scan.hpp"
#include "loopd/verify/verify.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;

namespace {
double json_number(double v) { return std::isfinite(v) ? v : 1e300; }

/// @brief What one verification found, with what it was given: printed as a table or as JSON.
struct Outcome {
  VerifyResult r;
  PreparedScan query, match;
  SensorEstimate query_seen, match_seen;
  std::string sensor;
  double scale_query = 0.0, scale_match = 0.0;
};

void print_json(const Outcome& o) {
  const VerifyResult& r = o.r;
  const PreparedScan &query = o.query, &match = o.match;
  double T[16];
  to_row_major(r.T_match_query, T);
  nlohmann::json j;
  j["accepted"] = r.accepted;
  j["stage"] = to_string(r.stage);
  j["reason"] = r.reason;
  j["T_match_query"] = std::vector<double>(T, T + 16);
  j["scores"] = {{"lcp_fraction", r.lcp_fraction},
                 {"icp_residual", r.icp_residual},
                 {"icp_fitness", r.icp_fitness},
                 {"degeneracy", json_number(r.degeneracy)},
                 {"degenerate", r.degenerate},
                 {"hungarian_consistency", r.hungarian_consistency},
                 {"icp_iterations", r.icp_iterations},
                 {"icp_converged", r.icp_converged},
                 {"clusters_query", r.clusters_query},
                 {"clusters_match", r.clusters_match},
                 {"clusters_matched", r.clusters_matched}};
  // Top-level copies of the scores for flat consumers.
  for (const auto& [k, v] : j["scores"].items()) j[k] = v;
  j["ms"] = {{"fourpcs", r.ms_fourpcs},         {"gicp", r.ms_gicp},
             {"hungarian", r.ms_hungarian},     {"total", r.ms_total},
             {"prepare_query", query.ms_total}, {"prepare_match", match.ms_total}};
  std::vector<double> info(r.information.data(), r.information.data() + 36);  // (t, r) order, base/information.hpp
  j["information"] = info;
  j["points"] = {{"query", query.points.size()}, {"match", match.points.size()}};
  j["sensor"] = {{"choice", o.sensor}, {"query", o.query_seen.describe()}, {"match", o.match_seen.describe()}};
  j["scene_scale"] = {{"query", o.scale_query}, {"match", o.scale_match}};
  j["bytes"] = {{"query", query.bytes()}, {"match", match.bytes()}};
  tools::print_json_line(j);
}

void print_table(const Outcome& o) {
  const VerifyResult& r = o.r;
  const PreparedScan &query = o.query, &match = o.match;
  double T[16];
  to_row_major(r.T_match_query, T);
  std::cout << (r.accepted ? "ACCEPTED" : "REJECTED") << " at stage " << to_string(r.stage) << (r.reason.empty() ? "" : ": " + r.reason) << "\n\n";
  tools::Table scores({"score", "value"});
  scores.add({"4PCS LCP fraction", tools::fmt(r.lcp_fraction)});
  scores.add({"GICP residual [m]", tools::fmt(r.icp_residual)});
  scores.add({"GICP fitness", tools::fmt(r.icp_fitness)});
  scores.add({"GICP iterations / converged", std::to_string(r.icp_iterations) + " / " + (r.icp_converged ? "yes" : "no")});
  scores.add({"degeneracy (cond. number)", tools::fmt(r.degeneracy, 1) + (r.degenerate ? "  DEGENERATE" : "")});
  scores.add({"Hungarian consistency", tools::fmt(r.hungarian_consistency) + " (" + std::to_string(r.clusters_matched) + " of " +
                                           std::to_string(r.clusters_query) + "/" + std::to_string(r.clusters_match) + ")"});
  std::cout << scores.str() << "\n";
  tools::Table ms({"stage", "ms"});
  ms.add({"prepare query", tools::fmt(query.ms_total, 1)});
  ms.add({"prepare match", tools::fmt(match.ms_total, 1)});
  ms.add({"4PCS", tools::fmt(r.ms_fourpcs, 1)});
  ms.add({"GICP", tools::fmt(r.ms_gicp, 1)});
  ms.add({"Hungarian", tools::fmt(r.ms_hungarian, 2)});
  ms.add({"verify total", tools::fmt(r.ms_total, 1)});
  std::cout << ms.str() << "\nT_match_query:\n";
  for (int i = 0; i < 4; ++i)
    std::cout << "  " << tools::fmt(T[4 * i], 5) << " " << tools::fmt(T[4 * i + 1], 5) << " " << tools::fmt(T[4 * i + 2], 5) << " "
              << tools::fmt(T[4 * i + 3], 4) << "\n";
  std::cout << "sensor " << o.sensor << ": query " << o.query_seen.describe() << "; match " << o.match_seen.describe() << "\n";
  std::cout << "scene scale [m]: query " << tools::fmt(o.scale_query, 1) << ", match " << tools::fmt(o.scale_match, 1) << "\n";
  std::cout << "points: query " << query.points.size() << ", match " << match.points.size() << "; keyframe bytes: " << query.bytes() << ", "
            << match.bytes() << "\n";
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app("loopd-verify: verify a loop candidate between two scans (4PCS, GICP, degeneracy, Hungarian centroid check)");
  std::string query_file, match_file, sensor, config_path;
  bool json = false;
  // The daemon's settings (its defaults, or --config's), so a decision of loopd can be reproduced by hand; the options
  // below override them.
  DaemonConfig daemon_config;
  PrepareConfig prep_cli = daemon_config.engine.detector.prepare;
  VerifyConfig cfg_cli = daemon_config.engine.detector.verify;
  int threads = 2;
  std::vector<double> guess;
  app.add_option("QUERY", query_file, "query scan (.bin KITTI, .pcd, .ply)")->required();
  app.add_option("MATCH", match_file, "match (older) scan")->required();
  app.add_option("--config", config_path, "loopd's YAML config: the same sensor, keyframe cloud and verification settings as the daemon");
  app.add_option("--sensor", sensor,
                 "lidar model for the range image: auto (rings read from each scan, loopd's default), " + sensor_choices() + "; 'none' is auto");
  app.add_option("--voxel", prep_cli.voxel_size, "voxel size [m]")->capture_default_str();
  app.add_option("--max-range", prep_cli.max_range, "crop range [m]")->capture_default_str();
  app.add_option("--normal-coherence", prep_cli.range_image_normal_coherence,
                 "GICP normals from the range image, none where a voxel's normals agree less than this; 0: k-nearest-neighbour PCA")
      ->capture_default_str();
  app.add_option("--normal-k", prep_cli.normal_k_neighbors, "neighbours for the k-nearest-neighbour normals")->capture_default_str();
  app.add_option("--threads", threads, "threads for GICP and normals")->capture_default_str();
  app.add_option("--guess", guess, "skip 4PCS: GICP starts from this T_match_query (16 row-major numbers)")->expected(16);
  app.add_option("--min-lcp", cfg_cli.min_lcp_fraction, "4PCS LCP fraction needed")->capture_default_str();
  app.add_option("--min-fitness", cfg_cli.min_icp_fitness, "GICP inlier share needed")->capture_default_str();
  app.add_option("--max-residual", cfg_cli.max_icp_residual, "GICP residual allowed [m]")->capture_default_str();
  app.add_option("--max-degeneracy", cfg_cli.max_degeneracy_ratio, "translational condition number allowed")->capture_default_str();
  app.add_option("--min-consistency", cfg_cli.min_hungarian_consistency, "cluster centroid share needed")->capture_default_str();
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;

  std::string error;
  if (!config_path.empty() && !load_config(config_path, &daemon_config, &error)) {
    std::cerr << "loopd-verify: --config " << config_path << ": " << error << "\n";
    return loopd::tools::kExitUsage;
  }
  LoopDetectorConfig& detector = daemon_config.engine.detector;
  if (sensor == "none") sensor = "auto";
  if (!sensor.empty() && !apply_sensor_preset(sensor, &daemon_config, &error)) {
    std::cerr << "loopd-verify: --sensor: " << error << "\n";
    return loopd::tools::kExitUsage;
  }
  if (auto err = detector.validate()) {
    std::cerr << "loopd-verify: " << *err << "\n";
    return loopd::tools::kExitUsage;
  }
  const CloudFile query_read = read_cloud_file(query_file), match_read = query_read.ok ? read_cloud_file(match_file) : CloudFile{};
  if (!query_read.ok || !match_read.ok) {
    std::cerr << "loopd-verify: " << (query_read.ok ? match_read.error : query_read.error) << "\n";
    return loopd::tools::kExitUsage;
  }
  const PointCloud& query_cloud = query_read.cloud;
  const PointCloud& match_cloud = match_read.cloud;
  PrepareConfig prep = detector.prepare;
  // The query's scene scale sets what the daemon needs of it (LoopDetectorConfig::small_scene_scale).
  VerifyConfig cfg = verify_config_for_scene(detector, scene_scale(query_cloud));
  const auto given = [&](const char* name) { return app.count(name) > 0; };
  if (given("--voxel")) prep.voxel_size = prep_cli.voxel_size;
  if (given("--max-range")) prep.max_range = prep_cli.max_range;
  if (given("--normal-coherence")) prep.range_image_normal_coherence = prep_cli.range_image_normal_coherence;
  if (given("--normal-k")) prep.normal_k_neighbors = prep_cli.normal_k_neighbors;
  if (given("--min-lcp")) cfg.min_lcp_fraction = cfg_cli.min_lcp_fraction;
  if (given("--min-fitness")) cfg.min_icp_fitness = cfg_cli.min_icp_fitness;
  if (given("--max-residual")) cfg.max_icp_residual = cfg_cli.max_icp_residual;
  if (given("--max-degeneracy")) cfg.max_degeneracy_ratio = cfg_cli.max_degeneracy_ratio;
  if (given("--min-consistency")) cfg.min_hungarian_consistency = cfg_cli.min_hungarian_consistency;
  const std::optional<LidarModel> model = sensor_model_from_choice(detector.sensor, detector.sensor_elevations_deg, detector.sensor_columns);
  prep.num_threads = threads;
  cfg.gicp.num_threads = threads;
  cfg.four_pcs.num_threads = threads;
  if (auto err = prep.validate()) {
    std::cerr << "loopd-verify: " << *err << "\n";
    return loopd::tools::kExitUsage;
  }
  if (auto err = cfg.validate()) {
    std::cerr << "loopd-verify: " << *err << "\n";
    return loopd::tools::kExitUsage;
  }
  SensorEstimate query_seen, match_seen;
  const PreparedScan query = prepare_scan(query_cloud, model_for_scan(model, query_cloud, &query_seen), prep);
  const PreparedScan match = prepare_scan(match_cloud, model_for_scan(model, match_cloud, &match_seen), prep);
  for (const SensorEstimate* seen : {&query_seen, &match_seen}) {
    const auto mismatch = model ? preset_mismatch(*model, *seen) : std::nullopt;
    if (mismatch) std::cerr << "loopd-verify: WARNING: " << *mismatch << "\n";
  }
  VerifyResult r;
  if (guess.size() == 16) {
    r = verify_from_guess(query, match, from_row_major(guess.data()), cfg);
  } else {
    r = verify(query, match, cfg);
  }
  const Outcome outcome{r, query, match, query_seen, match_seen, detector.sensor, scene_scale(query_cloud), scene_scale(match_cloud)};
  if (json)
    print_json(outcome);
  else
    print_table(outcome);
  return 0;
}
