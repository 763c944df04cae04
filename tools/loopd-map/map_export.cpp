// loopd-map export-cloud / export-octomap: the corrected 3D map (or the odometry one) built from the map's keyframe
// clouds (src/loopd/map3d/map_builder.hpp), written as .pcd / .ply or as an OctoMap .bt.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>

#include "loopd/io/cloud_writer.hpp"
#include "map_build_options.hpp"
#include "map_commands.hpp"
#include "tool_output.hpp"

namespace loopd::tools {
namespace {

std::int64_t file_bytes(const std::string& path) {
  std::error_code ec;
  const auto n = std::filesystem::file_size(path, ec);
  return ec ? 0 : static_cast<std::int64_t>(n);
}

void report(const MapBuildStats& s, const KeyframePoses& poses, const MapBuildOptions& o, double seconds, const std::string& what,
            std::int64_t points, const CommandOptions& options) {
  Table t({"", "value"});
  t.add({"keyframes (" + std::string(o.odometry ? "odometry poses" : "corrected poses") + ")", std::to_string(s.keyframes)});
  t.add({"  without a map cloud", std::to_string(s.keyframes_without_cloud)});
  const auto retired = std::count_if(poses.poses.begin(), poses.poses.end(), [](const KeyframePose& p) { return p.retired; });
  t.add({"keyframes retired (left out: their places are kept by others)", std::to_string(retired)});
  t.add({"map-cloud points read", std::to_string(s.points_in)});
  t.add({"octree leaves (" + fmt(o.resolution, 2) + " m)",
         std::to_string(s.octree_leaves) + " (" + fmt(static_cast<double>(s.octree_bytes) / 1048576.0, 1) + " MiB)"});
  if (what == "cloud") {
    t.add({"points in space seen free later (dropped)", std::to_string(s.points_cleared)});
    t.add({"voxels merged (" + fmt(o.voxel, 2) + " m)", std::to_string(s.points_merged)});
    t.add({"roadway noise removed (tunnel sections / cut)",
           std::to_string(s.roadway_removed) + " (" + std::to_string(s.roadway.tunnel_stations) + " / " + std::to_string(s.roadway.stations) + ")"});
    t.add({"statistical outliers removed", std::to_string(s.outliers_removed)});
    t.add({"points written", std::to_string(points)});
  }
  t.add({"written to", o.out + " (" + fmt(static_cast<double>(file_bytes(o.out)) / 1048576.0, 1) + " MiB)"});
  t.add({"seconds (ray casting / merge / filters / all)",
         fmt(s.seconds_octree, 1) + " / " + fmt(s.seconds_merge, 1) + " / " + fmt(s.seconds_filter, 1) + " / " + fmt(seconds, 1)});
  t.add({"peak RSS [MiB]", fmt(static_cast<double>(peak_rss_bytes()) / 1048576.0, 0)});
  std::cout << t.str();
  if (!options.json) return;
  print_json_line({{"out", o.out},
                   {"format", what},
                   {"poses", o.odometry ? "odometry" : "corrected"},
                   {"correction_revision", poses.correction_revision},
                   {"keyframes", s.keyframes},
                   {"keyframes_without_cloud", s.keyframes_without_cloud},
                   {"keyframes_retired", retired},
                   {"points_in", s.points_in},
                   {"points_cleared", s.points_cleared},
                   {"points_merged", s.points_merged},
                   {"roadway_removed", s.roadway_removed},
                   {"tunnel_stations", s.roadway.tunnel_stations},
                   {"stations", s.roadway.stations},
                   {"outliers_removed", s.outliers_removed},
                   {"points", points},
                   {"octree_leaves", s.octree_leaves},
                   {"octree_bytes", s.octree_bytes},
                   {"bytes", file_bytes(o.out)},
                   {"seconds", seconds},
                   {"peak_rss_bytes", peak_rss_bytes()}});
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int run_export_cloud(MapStore& store, const MapBuildOptions& o, const CommandOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  MapBuildConfig config;
  KeyframePoses poses;
  std::vector<MapBuildKeyframe> keyframes;
  if (!prepare_build(store, o, options.progress, &config, &poses, &keyframes)) return kExitBadInput;
  CloudWriter writer;  // opened first: a path it cannot write is refused before minutes of work
  if (auto e = writer.open(o.out)) {
    std::cerr << "loopd-map: " << *e << "\n";
    return kExitBadInput;
  }
  std::string read_error;
  const MapBuildResult built = build_map(keyframes, store_clouds(store, &read_error), config, phase_progress(options.progress));
  if (!read_error.empty()) {
    std::cerr << "loopd-map: " << read_error << "\n";
    return kExitBadInput;
  }
  const bool has_i = built.map.has_intensity();
  for (std::size_t i = 0; i < built.map.size(); ++i) writer.add(built.map.points[i], has_i ? built.map.intensity[i] : 0.0f);
  const std::int64_t points = writer.points_written();
  if (auto e = writer.close()) {
    std::cerr << "loopd-map: " << *e << "\n";
    return kExitBadInput;
  }
  report(built.stats, poses, o, seconds_since(t0), "cloud", points, options);
  return kExitOk;
}

int run_export_octomap(MapStore& store, const MapBuildOptions& o, const CommandOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  MapBuildConfig config;
  KeyframePoses poses;
  std::vector<MapBuildKeyframe> keyframes;
  if (!prepare_build(store, o, options.progress, &config, &poses, &keyframes)) return kExitBadInput;
  std::string read_error;
  OccupancyMap octree(config.octree);
  MapBuildStats stats;
  insert_keyframes(keyframes, store_clouds(store, &read_error), phase_progress(options.progress), &octree, &stats);
  stats.seconds_octree = seconds_since(t0);
  if (!read_error.empty()) {
    std::cerr << "loopd-map: " << read_error << "\n";
    return kExitBadInput;
  }
  if (auto e = octree.write_binary(o.out)) {
    std::cerr << "loopd-map: " << *e << "\n";
    return kExitBadInput;
  }
  report(stats, poses, o, seconds_since(t0), "octomap", 0, options);
  return kExitOk;
}

}  // namespace loopd::tools
