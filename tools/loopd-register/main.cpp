// loopd-register QUERY MATCH: global registration of two scans (plane-based 4PCS, Vlaminck 2019 Sec. 4.2) without
// an initial guess. Prints T_match_query (maps query points into the match frame), the LCP fraction and ms.
#include <CLI/CLI.hpp>
#include <iostream>

#include "loopd/runtime/daemon_config.hpp"
#include "loopd/base/lidar_model.hpp"
#include "loopd/base/sensor_estimate.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/pipeline/register_scans.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;

int main(int argc, char** argv) {
  CLI::App app("loopd-register: align QUERY onto MATCH (plane-based 4PCS, no initial guess)");
  std::string query_file, match_file, sensor, config_path;
  bool json = false;
  ScanRegistrationConfig config;
  app.add_option("QUERY", query_file, "query scan (.bin KITTI, .pcd, .ply)")->required();
  app.add_option("MATCH", match_file, "match scan (.bin KITTI, .pcd, .ply)")->required();
  app.add_option("--sensor,--lidar", sensor,
                 "lidar model for the range image: auto (rings read from each scan, loopd's default), " + sensor_choices());
  app.add_option("--config", config_path, "loopd's YAML config: its sensor, keyframe cloud and 4PCS settings (as the daemon registers keyframes)");
  app.add_option("--voxel", config.prepare.voxel_size, "voxel size of the LCP cloud [m]")->capture_default_str();
  app.add_option("--delta", config.four_pcs.delta, "LCP distance [m]")->capture_default_str();
  app.add_option("--max-bases", config.four_pcs.max_bases, "coplanar bases tried")->capture_default_str();
  app.add_option("--threads", config.four_pcs.num_threads, "threads scoring congruent sets")->capture_default_str();
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;

  DaemonConfig daemon_config;
  std::string error;
  if (!config_path.empty()) {
    if (!load_config(config_path, &daemon_config, &error)) {
      std::cerr << "loopd-register: --config " << config_path << ": " << error << "\n";
      return loopd::tools::kExitUsage;
    }
    const ScanRegistrationConfig cli = config;
    config.prepare = daemon_config.engine.detector.prepare;
    config.four_pcs = daemon_config.engine.detector.verify.four_pcs;
    if (app.count("--voxel")) config.prepare.voxel_size = cli.prepare.voxel_size;
    if (app.count("--delta")) config.four_pcs.delta = cli.four_pcs.delta;
    if (app.count("--max-bases")) config.four_pcs.max_bases = cli.four_pcs.max_bases;
    config.four_pcs.num_threads = cli.four_pcs.num_threads;
  }
  if (!sensor.empty() && !apply_sensor_preset(sensor, &daemon_config, &error)) {
    std::cerr << "loopd-register: --sensor: " << error << "\n";
    return loopd::tools::kExitUsage;
  }
  const LoopDetectorConfig& detector = daemon_config.engine.detector;
  if (auto e = validate_sensor_choice(detector.sensor, detector.sensor_elevations_deg, detector.sensor_columns)) {
    std::cerr << "loopd-register: " << *e << "\n";
    return loopd::tools::kExitUsage;
  }
  const std::optional<LidarModel> model = sensor_model_from_choice(detector.sensor, detector.sensor_elevations_deg, detector.sensor_columns);
  if (auto e = config.validate()) {
    std::cerr << "loopd-register: " << *e << "\n";
    return loopd::tools::kExitUsage;
  }
  const CloudFile query_read = read_cloud_file(query_file), match_read = query_read.ok ? read_cloud_file(match_file) : CloudFile{};
  if (!query_read.ok || !match_read.ok) {
    std::cerr << "loopd-register: " << (query_read.ok ? match_read.error : query_read.error) << "\n";
    return loopd::tools::kExitUsage;
  }
  const PointCloud& query = query_read.cloud;
  const PointCloud& match = match_read.cloud;
  double ms_prepare = 0;
  // One model for both scans (register_scans prepares them together): the preset, or what the match scan shows.
  SensorEstimate seen;
  const LidarModel* m = model_for_scan(model, match, &seen);
  if (model) {
    if (auto mismatch = preset_mismatch(*model, seen)) std::cerr << "loopd-register: WARNING: " << *mismatch << "\n";
  }
  const FourPcsResult r = register_scans(query, match, m, config, &ms_prepare);
  double T[16];
  to_row_major(r.T_target_source, T);
  if (json) {
    tools::print_json_line({{"T_match_query", std::vector<double>(T, T + 16)},
                            {"lcp", r.lcp_fraction},
                            {"ms", r.ms},
                            {"ms_prepare", ms_prepare},
                            {"success", r.success},
                            {"reason", r.reason},
                            {"bases", r.bases_tried},
                            {"congruent_sets", r.congruent_sets}});
    return r.success ? loopd::tools::kExitOk : loopd::tools::kExitProblem;  // no alignment found: it ran, the scans did not register
  }
  tools::Table t({"query", "match", "success", "lcp", "bases", "congruent sets", "4pcs ms", "prepare ms"});
  t.add({query_file, match_file, r.success ? "yes" : "no: " + r.reason, tools::fmt(r.lcp_fraction), std::to_string(r.bases_tried),
         std::to_string(r.congruent_sets), tools::fmt(r.ms, 1), tools::fmt(ms_prepare, 1)});
  std::cout << t.str() << "T_match_query (query -> match):\n";
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) std::cout << (j ? " " : "  ") << tools::fmt(T[i * 4 + j], 6);
    std::cout << "\n";
  }
  return r.success ? 0 : 2;
}
