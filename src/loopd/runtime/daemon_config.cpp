#include "loopd/runtime/daemon_config.hpp"
#include "loopd/records/vehicle_sessions.hpp"
#include "loopd/store/store_uri.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

namespace loopd {
namespace {

/// Walks every config field once, either loading it from YAML or dumping it (one list of fields, two uses).
class Binder {
 public:
  enum class Mode { kLoad, kDump };
  Binder(Mode mode, YAML::Node root) : mode_(mode), root_(std::move(root)) {}

  template <typename T>
  void field(const std::string& path, T& value) {
    known_.insert(path);
    if (mode_ == Mode::kDump) {
      dump_[path] = {to_text(value), std::is_same_v<T, std::string>};
      return;
    }
    if (!error_.empty()) return;
    YAML::Node node = lookup(path);
    if (!node) return;
    try {
      const T parsed = node.as<T>();
      if constexpr (std::is_same_v<T, std::vector<double>>) {
        if (!std::all_of(parsed.begin(), parsed.end(), [](double x) { return std::isfinite(x); })) {
          error_ = at(node) + path + ": expected finite numbers";
          return;
        }
      }
      if constexpr (std::is_floating_point_v<T>) {
        if (!std::isfinite(parsed)) {
          error_ = at(node) + path + ": expected a finite number, got '" + node.Scalar().substr(0, 64) + "'";
          return;
        }
      }
      value = parsed;
    } catch (const YAML::Exception&) {
      error_ = at(node) + path + ": expected " + type_name(value) + ", got '" +
               (node.IsScalar() ? node.Scalar().substr(0, 64) : std::string("a map or list")) + "'";
    }
  }
  /// An enum stored as one of several names.
  template <typename E>
  void choice(const std::string& path, E& value, const std::vector<std::pair<std::string, E>>& names) {
    std::string text;
    for (const auto& [n, v] : names)
      if (v == value) text = n;
    known_.insert(path);
    if (mode_ == Mode::kDump) {
      dump_[path] = {text, false};
      return;
    }
    if (!error_.empty()) return;
    YAML::Node node = lookup(path);
    if (!node) return;
    const std::string got = node.IsScalar() ? node.Scalar().substr(0, 64) : "";
    for (const auto& [n, v] : names)
      if (n == got) {
        value = v;
        return;
      }
    std::string options;
    for (const auto& [n, v] : names) options += (options.empty() ? "" : ", ") + n;
    error_ = at(node) + path + ": expected one of " + options + ", got '" + got + "'";
  }
  /// Reports keys present in the YAML that no field consumed.
  void check_unknown() {
    if (!error_.empty() || mode_ != Mode::kLoad) return;
    walk(root_, "");
  }
  const std::string& error() const { return error_; }
  /// Dumped values: path -> (YAML text, whether it is a string).
  const std::map<std::string, std::pair<std::string, bool>>& dumped() const { return dump_; }

 private:
  /// "line N: " of a node (1-based), "" when yaml-cpp has no position for it.
  static std::string at(const YAML::Node& node) {
    const YAML::Mark m = node.Mark();
    return m.is_null() ? std::string() : "line " + std::to_string(m.line + 1) + ": ";
  }
  YAML::Node lookup(const std::string& path) const {
    // Read-only walk: const operator[] inserts nothing, and reset() re-points the handle (operator= would overwrite
    // the node it refers to).
    YAML::Node node;
    node.reset(root_);
    std::stringstream ss(path);
    std::string part;
    while (std::getline(ss, part, '.')) {
      if (!node.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
      const YAML::Node& map = node;
      YAML::Node child = map[part];
      if (!child) return YAML::Node(YAML::NodeType::Undefined);
      node.reset(child);
    }
    return node;
  }
  void walk(const YAML::Node& node, const std::string& prefix) {
    if (!error_.empty()) return;
    if (!node.IsMap()) {
      if (!prefix.empty() && !known_.count(prefix)) error_ = prefix + ": unknown configuration key";
      return;
    }
    for (const auto& kv : node) {
      if (!kv.first.IsScalar()) {
        error_ = at(kv.first) + (prefix.empty() ? std::string() : prefix + ": ") + "a key must be a plain name, not a map or list";
        return;
      }
      const std::string key = prefix.empty() ? kv.first.Scalar() : prefix + "." + kv.first.Scalar();
      walk(kv.second, key);
    }
  }
  static std::string type_name(const double&) { return "a number"; }
  static std::string type_name(const int&) { return "an integer"; }
  static std::string type_name(const std::int64_t&) { return "an integer"; }
  static std::string type_name(const bool&) { return "true or false"; }
  static std::string type_name(const std::string&) { return "a string"; }
  static std::string type_name(const std::vector<double>&) { return "a list of numbers"; }
  /// The shortest decimal text (6 to 17 digits) that reads back as exactly `v`.
  static std::string shortest_exact(double v) {
    std::string text;
    for (int digits = 6; digits <= 17; ++digits) {
      std::ostringstream os;
      os << std::setprecision(digits) << v;
      text = os.str();
      if (std::strtod(text.c_str(), nullptr) == v) break;
    }
    return text;
  }
  template <typename T>
  static std::string to_text(const T& v) {
    std::ostringstream os;
    if constexpr (std::is_same_v<T, bool>)
      os << (v ? "true" : "false");
    else if constexpr (std::is_same_v<T, std::string>)
      os << v;  // emitted as a string node (quoted by the emitter where needed)
    else if constexpr (std::is_floating_point_v<T>)
      os << shortest_exact(v);  // loads back to the same double
    else if constexpr (std::is_same_v<T, std::vector<double>>) {
      os << "[";
      for (std::size_t i = 0; i < v.size(); ++i) os << (i ? ", " : "") << shortest_exact(v[i]);
      os << "]";
    } else
      os << v;
    return os.str();
  }

  Mode mode_;
  YAML::Node root_;
  std::set<std::string> known_;
  std::map<std::string, std::pair<std::string, bool>> dump_;
  std::string error_;
};

/// The stage configs of the detector (descriptor, preparation, verification, correction).
void bind_stage_configs(Binder& b, LoopDetectorConfig& d) {
  M2dpConfig& m = d.m2dp;
  b.field("descriptor.l", m.num_rings_l);
  b.field("descriptor.t", m.num_sectors_t);
  b.field("descriptor.p", m.num_azimuths_p);
  b.field("descriptor.q", m.num_elevations_q);
  b.choice("descriptor.frame", m.frame, {{"gravity", M2dpFrame::kGravityAligned}, {"pca", M2dpFrame::kPca}});
  b.choice("descriptor.backend", m.backend, {{"auto", Backend::kAuto}, {"opencl", Backend::kOpenCl}, {"cpu", Backend::kCpu}});
  b.field("descriptor.opencl_device", m.opencl_device);
  b.field("descriptor.max_points", m.max_points);

  PrepareConfig& p = d.prepare;
  b.field("keyframe_cloud.voxel_size", p.voxel_size);
  b.field("keyframe_cloud.min_range", p.min_range);
  b.field("keyframe_cloud.max_range", p.max_range);
  int max_points = static_cast<int>(p.max_points);
  b.field("keyframe_cloud.max_points", max_points);
  p.max_points = static_cast<std::size_t>(std::max(0, max_points));
  SegmentationConfig& sg = p.segmentation;
  b.field("segmentation.max_neighbor_distance", sg.max_neighbor_distance);
  b.field("segmentation.distance_range_scale", sg.distance_range_scale);
  b.field("segmentation.max_normal_angle_deg", sg.max_normal_angle_deg);
  b.field("segmentation.min_cluster_points", sg.min_cluster_points);
  b.field("segmentation.plane_rms_tolerance", sg.plane_rms_tolerance);
  b.field("segmentation.max_clusters", sg.max_clusters);

  VerifyConfig& v = d.verify;
  b.field("fourpcs.delta", v.four_pcs.delta);
  b.field("fourpcs.max_bases", v.four_pcs.max_bases);
  b.field("fourpcs.min_base_width", v.four_pcs.min_base_width);
  b.field("fourpcs.max_angle_deviation_deg", v.four_pcs.max_angle_deviation_deg);
  b.field("fourpcs.max_tilt_deg", v.four_pcs.max_tilt_deg);
  b.field("fourpcs.lcp_sample_points", v.four_pcs.lcp_sample_points);
  b.field("fourpcs.num_threads", v.four_pcs.num_threads);
  b.field("gicp.k_neighbors", v.gicp.k_neighbors);
  b.field("gicp.epsilon", v.gicp.epsilon);
  b.field("gicp.max_iterations", v.gicp.max_iterations);
  b.field("gicp.num_threads", v.gicp.num_threads);
  b.field("verify.min_points", v.min_points);
  b.field("verify.min_lcp_fraction", v.min_lcp_fraction);
  b.field("verify.max_icp_residual", v.max_icp_residual);
  b.field("verify.min_icp_fitness", v.min_icp_fitness);
  b.field("verify.max_degeneracy_ratio", v.max_degeneracy_ratio);
  b.field("verify.reject_degenerate", v.reject_degenerate);
  b.field("verify.hungarian_match_distance", v.hungarian_match_distance);
  b.field("verify.min_hungarian_consistency", v.min_hungarian_consistency);
  b.field("verify.reject_unjudgeable_consistency", v.reject_unjudgeable_consistency);

  LoopCorrectorConfig& c = d.correction;
  b.choice(
      "correction.method", c.method,
      {{"heuristic+graph", CorrectionMethod::kHeuristicThenGraph}, {"heuristic", CorrectionMethod::kHeuristic}, {"graph", CorrectionMethod::kGraph}});
  b.choice("correction.graph.loop_loss", c.graph.loop_loss,
           {{"cauchy", RobustLoss::kCauchy}, {"huber", RobustLoss::kHuber}, {"none", RobustLoss::kNone}});
  b.field("correction.graph_interval", c.graph_interval);
  b.field("correction.graph_interval_fraction", c.graph_interval_fraction);
  b.field("correction.graph_now_translation", c.graph_now_translation);
  b.field("correction.graph_now_rotation_deg", c.graph_now_rotation_deg);
  b.field("correction.graph.loop_loss_scale", c.graph.loop_loss_scale);
  b.field("correction.graph.odometry_translation_sigma", c.graph.odometry_translation_sigma);
  b.field("correction.graph.odometry_rotation_sigma", c.graph.odometry_rotation_sigma);
  b.field("correction.graph.max_iterations", c.graph.max_iterations);
  b.field("correction.graph.max_nodes", c.graph.max_nodes);
  b.field("correction.graph.max_loop_information", c.graph.max_loop_information);
  b.field("correction.graph.min_loop_information", c.graph.min_loop_information);
  b.field("correction.graph.reduce_chains", c.graph.reduce_chains);
  b.field("correction.steps.enabled", d.steps.enabled);
  b.field("correction.steps.max_translation_change", d.steps.max_translation_change);
  b.field("correction.steps.max_rotation_change_deg", d.steps.max_rotation_change_deg);
  b.field("correction.steps.min_fitness", d.steps.min_fitness);
  b.field("correction.steps.max_degeneracy", d.steps.max_degeneracy);
  b.field("correction.steps.translation_sigma", d.steps.translation_sigma);
  b.field("correction.steps.rotation_sigma", d.steps.rotation_sigma);
  b.field("correction.steps.tilt_from_odometry", d.steps.tilt_from_odometry);
  b.field("correction.steps.max_unskewed_motion", d.steps.max_unskewed_motion);
  b.field("correction.steps.max_unskewed_rotation_deg", d.steps.max_unskewed_rotation_deg);
  b.field("correction.graph.use_plane_constraints", c.graph.use_plane_constraints);
  b.field("correction.graph.plane_cell_size", d.plane_cell_size);
}

/// Global retrieval (the detector's second descriptor) and when sessions open.
void bind_retrieval_and_sessions(Binder& b, LoopDetectorConfig& d, SessionPolicy& sessions) {
  GlobalRetrievalConfig& r = d.retrieval;
  b.field("retrieval.enabled", r.enabled);
  b.field("retrieval.k", r.retrieval.k);
  b.field("retrieval.ring_candidates", r.retrieval.ring_candidates);
  double max_place_distance = r.retrieval.max_place_distance;
  b.field("retrieval.max_place_distance", max_place_distance);
  r.retrieval.max_place_distance = static_cast<float>(max_place_distance);
  b.field("retrieval.max_verified", r.max_verified);
  b.field("retrieval.lateral_shift", r.lateral_shift);
  b.field("retrieval.min_travel_gap", r.min_travel_gap);
  b.field("retrieval.max_drift_fraction", r.max_drift_fraction);
  b.field("retrieval.confirm_window", r.confirm_window);
  b.field("retrieval.confirm_translation", r.confirm_translation);
  b.field("retrieval.confirm_rotation_deg", r.confirm_rotation_deg);
  b.field("retrieval.descriptor.rings", r.descriptor.num_rings);
  b.field("retrieval.descriptor.sectors", r.descriptor.num_sectors);
  double max_range = r.descriptor.max_range, height_offset = r.descriptor.height_offset;
  b.field("retrieval.descriptor.max_range", max_range);
  b.field("retrieval.descriptor.height_offset", height_offset);
  r.descriptor.max_range = static_cast<float>(max_range);
  r.descriptor.height_offset = static_cast<float>(height_offset);
  b.choice("sessions.on_odometry_reset", sessions.new_session_on_reset, {{"new_session", true}, {"stitch", false}});
  b.field("sessions.resume_max_gap", sessions.resume_max_gap);
}

void bind(Binder& b, DaemonConfig& c) {
  NodeConfig& n = c.node;
  b.field("lcm_url", n.lcm_url);
  b.field("channels.scan", n.scan_channel);
  b.field("channels.pose", n.pose_channel);
  b.field("channels.loop_event", n.loop_event_channel);
  b.field("channels.trajectory", n.trajectory_channel);
  b.field("channels.status", n.status_channel);
  b.field("input_queue_capacity", n.input_queue_capacity);
  b.field("log_every_n", n.log_every_n);
  b.field("status_period", n.status_period);
  b.field("watchdog_stall", n.watchdog_stall);
  b.choice("log_level", n.log_level, {{"error", LogLevel::kError}, {"warn", LogLevel::kWarn}, {"info", LogLevel::kInfo}});
  b.field("map.path", n.map.uri);
  b.field("map.synchronous", n.map.synchronous);
  b.field("map.cache_mb", n.map_cache_mb);
  b.field("map.clouds", c.engine.map_cloud.enabled);
  b.field("map.cloud_voxel", c.engine.map_cloud.voxel);
  b.field("map.cloud_min_range", c.engine.map_cloud.min_range);
  b.field("map.cloud_max_range", c.engine.map_cloud.max_range);
  b.field("map.cloud_quantum", c.engine.map_cloud.quantum);
  b.field("map.max_buffered_keyframes", n.max_buffered_keyframes);
  b.field("map.retry_period", n.map_retry_period);
  b.field("fleet.vehicle", n.fleet.vehicle);
  b.field("fleet.poll_interval", n.fleet.poll_interval);
  b.field("fleet.solve_every_keyframes", n.fleet.solve_every_keyframes);
  b.field("fleet.flush_timeout", n.fleet.flush_timeout);
  b.field("output.trajectory_min_move", n.trajectory_output.min_move);
  b.field("output.trajectory_min_turn_deg", n.trajectory_output.min_turn_deg);
  b.field("output.trajectory_snapshot_period", n.trajectory_output.snapshot_period);

  EngineConfig& e = c.engine;
  b.field("threads", e.num_threads);
  b.field("queue_capacity", e.queue_capacity);
  b.field("max_points_per_scan", e.max_points_per_scan);
  b.field("input.clock_jump", e.clock_jump);
  b.field("input.max_odometry_speed", e.max_odometry_speed);
  b.field("association.tolerance", e.association.tolerance);
  b.field("association.hold_time", e.association.hold_time);
  b.field("association.max_pending_scans", e.association.max_pending_scans);
  b.field("association.max_poses", e.association.max_poses);
  b.field("deskew.enabled", e.deskew.enabled);
  b.field("deskew.from_scans", e.deskew_from_scans);
  b.field("deskew.compensated_upstream", e.compensated_upstream);
  b.field("deskew.sweep_motion.voxel_size", e.sweep_motion.voxel_size);
  b.field("deskew.sweep_motion.max_input_points", e.sweep_motion.max_input_points);
  b.field("deskew.sweep_motion.rounds", e.sweep_motion.rounds);
  b.field("deskew.sweep_motion.max_source_points", e.sweep_motion.gicp.max_source_points);
  b.field("submap.enabled", e.submap.enabled);
  b.field("submap.max_coverage_deg", e.submap.max_coverage_deg);
  int submap_min_points = static_cast<int>(e.submap.min_points);
  b.field("submap.min_points", submap_min_points);
  e.submap.min_points = static_cast<std::size_t>(std::max(0, submap_min_points));
  b.field("submap.window", e.submap.window);
  b.field("submap.max_travel", e.submap.max_travel);
  b.field("submap.max_scans", e.submap.max_scans);
  b.field("submap.confirm", e.submap.confirm);
  b.field("deskew.max_sweep", e.deskew.max_sweep);
  b.field("deskew.max_extrapolation", e.deskew.max_extrapolation);
  b.field("deskew.max_pose_gap", e.deskew.max_pose_gap);
  b.field("deskew.time_bins", e.deskew.time_bins);

  LoopDetectorConfig& d = e.detector;
  b.field("sensor", d.sensor);
  b.field("sensor_elevations_deg", d.sensor_elevations_deg);
  b.field("sensor_columns", d.sensor_columns);
  b.field("keyframe.min_distance", d.keyframe.min_distance);
  b.field("keyframe.min_rotation_deg", d.keyframe.min_rotation_deg);
  b.field("keyframe.max_interval", d.keyframe.max_interval);
  b.field("keyframe.spacing_per_scale", d.keyframe.spacing_per_scale);
  b.field("keyframe.min_spacing", d.keyframe.min_spacing);
  b.field("gate.travel_fraction", d.gate.travel_fraction);
  b.field("gate.min_radius", d.gate.min_radius);
  b.field("gate.max_radius", d.gate.max_radius);
  b.field("gate.min_index_gap", d.gate.min_index_gap);
  b.field("gate.min_travel_gap", d.gate.min_travel_gap);
  b.field("gate.travel_gap_per_scale", d.gate.travel_gap_per_scale);
  b.field("gate.min_travel_gap_floor", d.gate.min_travel_gap_floor);
  b.field("gate.travel_gap_per_radius", d.gate.travel_gap_per_radius);
  b.field("descriptor.max_distance", d.max_descriptor_distance);
  b.field("verify.small_scene_scale", d.small_scene_scale);
  b.field("verify.max_prior_rotation_deg", d.max_prior_rotation_deg);
  b.field("descriptor.max_candidates", d.max_candidates_per_keyframe);
  b.field("verify.guided_window", d.guided_window);
  bind_stage_configs(b, d);
  bind_retrieval_and_sessions(b, d, e.sessions);
}

}  // namespace

bool apply_sensor_preset(const std::string& sensor, DaemonConfig* config, std::string* error) {
  if (sensor == "custom") {  // its table comes with the config's sensor_elevations_deg (checked by validate)
    config->engine.detector.sensor = sensor;
    return true;
  }
  if (auto e = validate_sensor_choice(sensor)) {
    *error = *e;
    return false;
  }
  config->engine.detector.sensor = sensor;
  return true;
}

namespace {

bool load_config_text_unguarded(const std::string& yaml, DaemonConfig* config, std::string* error) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& ex) {
    *error = std::string("YAML syntax: ") + ex.what();
    return false;
  }
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) {
    *error = "the config must be a YAML map of keys";
    return false;
  }
  // The sensor preset first, so explicit keys override what it implies.
  if (root["sensor"] && root["sensor"].IsScalar() && !apply_sensor_preset(root["sensor"].Scalar(), config, error)) return false;
  Binder b(Binder::Mode::kLoad, root);
  bind(b, *config);
  b.check_unknown();
  if (!b.error().empty()) {
    *error = b.error();
    return false;
  }
  if (auto e = config->node.validate()) {
    *error = *e;
    return false;
  }
  if (auto e = config->engine.validate()) {
    *error = *e;
    return false;
  }
  return true;
}

/// A config file is small text: anything larger is not one (and /dev/zero never ends).
constexpr std::uintmax_t kMaxConfigBytes = 1 << 20;

}  // namespace

bool load_config_text(const std::string& yaml, DaemonConfig* config, std::string* error) {
  // yaml-cpp reports bad YAML with exceptions, some from places the binder cannot foresee (conversions, node
  // access): none may leave here. The config is only changed when the whole text is accepted.
  DaemonConfig candidate = *config;
  try {
    if (!load_config_text_unguarded(yaml, &candidate, error)) return false;
  } catch (const std::exception& ex) {
    *error = std::string("YAML: ") + ex.what();
    return false;
  }
  *config = candidate;
  return true;
}

bool load_config(const std::string& path, DaemonConfig* config, std::string* error) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) {
    *error = "cannot read config file " + path + " (no such file)";
    return false;
  }
  if (!std::filesystem::is_regular_file(status)) {
    *error = "cannot read config file " + path + (std::filesystem::is_directory(status) ? " (a directory)" : " (not a regular file)");
    return false;
  }
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec || size > kMaxConfigBytes) {
    *error = "config file " + path + " is " + std::to_string(size) + " bytes (at most " + std::to_string(kMaxConfigBytes) + ")";
    return false;
  }
  std::ifstream in(path);
  if (!in) {
    *error = "cannot read config file " + path;
    return false;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  if (!load_config_text(ss.str(), config, error)) {
    *error = path + ": " + *error;
    return false;
  }
  return true;
}

std::string dump_config(const DaemonConfig& config) {
  DaemonConfig copy = config;
  Binder b(Binder::Mode::kDump, YAML::Node());
  bind(b, copy);
  // Nest the dotted paths back into YAML.
  YAML::Node root(YAML::NodeType::Map);
  for (const auto& [path, value] : b.dumped()) {
    const std::string& text = value.first;  // (a lambda cannot capture structured bindings in C++17)
    const bool is_string = value.second;
    std::vector<std::string> parts;
    std::stringstream ss(path);
    std::string part;
    while (std::getline(ss, part, '.')) parts.push_back(part);
    std::function<void(YAML::Node, std::size_t)> set = [&](YAML::Node node, std::size_t i) {
      if (i + 1 == parts.size()) {
        if (is_string)
          node[parts[i]] = text;
        else
          node[parts[i]] = YAML::Load(text);
        return;
      }
      set(node[parts[i]], i + 1);
    };
    set(root, 0);
  }
  YAML::Emitter out;
  out << root;
  return std::string(out.c_str()) + "\n";
}

void apply_fleet(DaemonConfig* config) {
  NodeConfig& n = config->node;
  if (names_shared_map(n.map.uri) && n.fleet.vehicle < 0) n.fleet.vehicle = 0;
  n.map.vehicle = n.fleet.vehicle;
  config->engine.sessions.first_session = first_session_of(n.fleet.vehicle);
}

}  // namespace loopd
