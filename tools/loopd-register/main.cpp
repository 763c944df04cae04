// loopd-register QUERY MATCH: global registration of two scans (plane-based 4PCS, Vlaminck 2019 Sec. 4.2) without
// an initial guess. Prints T_match_query (maps query points into the match frame), the LCP fraction and ms.
#include <CLI/CLI.hpp>
#include <iostream>

#include "loopd/core/lidar_model.hpp"
#include "loopd/core/pose.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/pipeline/register_scans.hpp"
#include "tool_output.hpp"

using namespace loopd;

int main(int argc, char** argv) {
  CLI::App app("loopd-register: align QUERY onto MATCH (plane-based 4PCS, no initial guess)");
  std::string query_file, match_file, lidar;
  bool json = false;
  ScanRegistrationConfig config;
  app.add_option("QUERY", query_file, "query scan (.bin KITTI, .pcd, .ply)")->required();
  app.add_option("MATCH", match_file, "match scan (.bin KITTI, .pcd, .ply)")->required();
  app.add_option("--lidar", lidar, "lidar model for rings from elevation: vlp16 | hdl32 | hdl64 | os1-64 (default: bin elevations)");
  app.add_option("--voxel", config.prepare.voxel_size, "voxel size of the LCP cloud [m]")->capture_default_str();
  app.add_option("--delta", config.four_pcs.delta, "LCP distance [m]")->capture_default_str();
  app.add_option("--max-bases", config.four_pcs.max_bases, "coplanar bases tried")->capture_default_str();
  app.add_option("--threads", config.four_pcs.num_threads, "threads scoring congruent sets")->capture_default_str();
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  CLI11_PARSE(app, argc, argv);

  std::optional<LidarModel> model;
  if (!lidar.empty()) {
    model = lidar_model_from_name(lidar);
    if (!model) {
      std::cerr << "loopd-register: unknown lidar model '" << lidar << "'\n";
      return 1;
    }
  }
  if (auto e = config.validate()) {
    std::cerr << "loopd-register: " << *e << "\n";
    return 1;
  }
  const CloudFile query_read = read_cloud_file(query_file), match_read = query_read.ok ? read_cloud_file(match_file) : CloudFile{};
  if (!query_read.ok || !match_read.ok) {
    std::cerr << "loopd-register: " << (query_read.ok ? match_read.error : query_read.error) << "\n";
    return 1;
  }
  const PointCloud& query = query_read.cloud;
  const PointCloud& match = match_read.cloud;
  double ms_prepare = 0;
  const FourPcsResult r = register_scans(query, match, model ? &*model : nullptr, config, &ms_prepare);
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
    return r.success ? 0 : 2;
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
