#include "map_build_options.hpp"

#include <iostream>
#include <memory>

#include "tool_output.hpp"

namespace loopd::tools {

MapBuildConfig build_config(const MapBuildOptions& options) {
  MapBuildConfig c;
  c.voxel = options.voxel;
  c.octree.resolution = options.resolution;
  c.octree.ray_max_range = options.ray_range;
  c.octree.prob_hit = options.prob_hit;
  c.octree.prob_miss = options.prob_miss;
  c.clear_free_space = !options.keep_moving;
  c.roadway_noise = !options.keep_roadway_noise;
  c.statistical_outliers = !options.keep_outliers;
  return c;
}

bool prepare_build(MapStore& store, const MapBuildOptions& options, bool progress, MapBuildConfig* config, KeyframePoses* poses,
                   std::vector<MapBuildKeyframe>* keyframes) {
  *config = build_config(options);
  if (auto e = config->validate()) {
    std::cerr << "loopd-map: " << *e << "\n";
    return false;
  }
  std::optional<SessionId> session;
  if (options.session) session = static_cast<SessionId>(*options.session);
  if (const StoreStatus st = read_keyframe_poses(store, options.odometry, session, progress, poses); !st.ok()) {
    std::cerr << "loopd-map: " << st.message << "\n";
    return false;
  }
  if (poses->poses.empty()) {
    std::cerr << "loopd-map: the map holds no keyframes" << (options.session ? " of session " + std::to_string(*options.session) : "") << "\n";
    return false;
  }
  // A retired keyframe has no map cloud: its place is built from the keyframes kept there.
  for (const KeyframePose& p : poses->poses)
    if (!p.retired) keyframes->push_back({p.key, p.T});
  return true;
}

MapCloudSource store_clouds(MapStore& store, std::string* error) {
  return [&store, error](const KeyframeKey& key) -> std::optional<PointCloud> {
    StoreResult<PointCloud> read = store.get_map_cloud(key);
    if (read.ok()) return std::move(read.value);
    if (read.status.code != StoreStatus::Code::kNotFound && error->empty()) *error = read.status.message;
    return std::nullopt;
  };
}

MapBuildProgress phase_progress(bool enabled) {
  auto bar = std::make_shared<std::unique_ptr<Progress>>();
  auto phase = std::make_shared<std::string>();
  return [enabled, bar, phase](const char* name, std::size_t done, std::size_t total) {
    if (!enabled) return;
    if (*phase != name) {
      if (*bar) (*bar)->finish();
      *phase = name;
      *bar = std::make_unique<Progress>(std::string(name) == "octree" ? "ray casting keyframes" : "merging keyframes  ",
                                        static_cast<std::int64_t>(total));
    }
    if (!*bar) return;  // this phase's bar is finished
    (*bar)->update(static_cast<std::int64_t>(done));
    if (done == total) {
      (*bar)->finish();
      bar->reset();
    }
  };
}

}  // namespace loopd::tools
