#include "map_eval.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iostream>
#include <unordered_set>

#include "lcm_log.hpp"
#include "loopd/base/deskew.hpp"
#include "loopd/eval/pose_error.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/io/file_bytes.hpp"
#include "message_convert.hpp"
#include "tool_output.hpp"

namespace loopd::tools {
namespace {

constexpr std::size_t kMaxMoversBytes = std::size_t{64} << 20;  // a movers file is a few KB per moving car
constexpr double kFrameWarning = 1.0;                           // [m] odometry this far from ground truth at the start: frames differ

/// Poses sorted by utime with one pose per utime (PoseTrack needs strictly increasing stamps).
std::vector<StampedPose> sorted_unique(std::vector<StampedPose> poses) {
  std::stable_sort(poses.begin(), poses.end(), [](const StampedPose& a, const StampedPose& b) { return a.utime < b.utime; });
  poses.erase(std::unique(poses.begin(), poses.end(), [](const StampedPose& a, const StampedPose& b) { return a.utime == b.utime; }), poses.end());
  return poses;
}

/// The poses over [from, to] with two before and one after (the bracketing poses and a pair to extrapolate with), as
/// the daemon's ScanPoseAssociator hands them to deskew.
std::vector<StampedPose> poses_around(const std::vector<StampedPose>& poses, std::int64_t from, std::int64_t to) {
  auto lo = std::lower_bound(poses.begin(), poses.end(), from, [](const StampedPose& p, std::int64_t t) { return p.utime < t; });
  auto hi = std::upper_bound(poses.begin(), poses.end(), to, [](std::int64_t t, const StampedPose& p) { return t < p.utime; });
  lo -= std::min<std::ptrdiff_t>(2, lo - poses.begin());
  hi += std::min<std::ptrdiff_t>(1, poses.end() - hi);
  return {lo, hi};
}

/// Scans deskewed with, and placed at, one pose stream, cropped to a range and voxelised.
struct MapBuilder {
  MapBuilder(std::vector<StampedPose> stream, double leaf, double max_range)
      : poses(sorted_unique(std::move(stream))), voxels(leaf), range(max_range) {}
  void add(PointCloud cloud, std::int64_t utime);
  std::vector<StampedPose> poses;
  VoxelAccumulator voxels;
  double range;
  std::int64_t scans = 0, deskewed = 0, without_pose = 0;
};

void MapBuilder::add(PointCloud cloud, std::int64_t utime) {
  const std::optional<Eigen::Isometry3d> T_world_sensor = pose_at(poses, utime);
  if (!T_world_sensor) {
    ++without_pose;
    return;
  }
  if (cloud.has_time()) {
    // loopd-sim stamps a scan at the end of its sweep: the per-point times are negative.
    const auto [t0, t1] = time_span(cloud);
    const std::vector<StampedPose> sweep = poses_around(poses, utime + std::llround(t0 * 1e6), utime + std::llround(t1 * 1e6));
    if (deskew(DeskewConfig{}, sweep, utime, &cloud).applied()) ++deskewed;
  }
  const bool intensity = cloud.has_intensity();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d p = cloud.points[i].cast<double>();
    if (!p.allFinite() || p.norm() > range) continue;
    voxels.add((*T_world_sensor * p).cast<float>(), intensity ? cloud.intensity[i] : 0.f);
  }
  ++scans;
}

std::int64_t total_bytes(const std::vector<std::string>& paths) {
  std::int64_t total = 0;
  for (const auto& p : paths) {
    std::error_code ec;
    const auto n = std::filesystem::file_size(p, ec);
    if (!ec) total += static_cast<std::int64_t>(n);
  }
  return total;
}

using ScanSink = std::function<void(PointCloud&&, std::int64_t utime)>;

/// Every scan of the drive logs, decoded with the bounded decoder, one at a time into `sink`.
bool stream_scans(const std::vector<std::string>& drives, const EvalChannels& ch, bool quiet, const ScanSink& sink, std::int64_t* malformed,
                  std::string* error) {
  Progress bar("reading scans  ", 100, !quiet);
  const std::int64_t total = total_bytes(drives);
  std::int64_t done = 0, events = 0;
  for (const auto& path : drives) {
    LogReader reader;
    if (!reader.open(path, error)) return false;
    LogEvent ev;
    point_cloud_t msg;
    while (reader.next(&ev)) {
      done += LogReader::kEventHeaderBytes + static_cast<std::int64_t>(ev.channel.size() + ev.data.size());
      if ((++events % 64) == 0) bar.update(total > 0 ? done * 100 / total : 0);
      if (ev.channel != ch.scan) continue;
      PointCloud cloud;
      std::string why;
      if (!LogReader::decode(ev, &msg) || !from_message(msg, &cloud, &why)) {
        ++*malformed;
        continue;
      }
      sink(std::move(cloud), msg.utime);
    }
  }
  bar.finish();
  return true;
}

bool read_movers(const std::string& path, std::vector<MapMoverBox>* movers, std::string* error) {
  const FileBytes file = read_file_bytes(path, kMaxMoversBytes);
  if (!file.ok) {
    *error = file.error;
    return false;
  }
  if (auto e = parse_movers_json(file.bytes, movers)) {
    *error = path + ": " + *e;
    return false;
  }
  return true;
}

bool read_map(const std::string& path, PointCloud* cloud, std::string* error) {
  CloudFile file = read_cloud_file(path);
  if (!file.ok) {
    *error = file.error;
    return false;
  }
  *cloud = std::move(file.cloud);
  return true;
}

/// Utimes of the corrected trajectory's keyframes of its first session (later sessions have their own odometry frames).
std::unordered_set<std::int64_t> odometry_keyframes(const EvalInput& input, std::vector<std::string>* warnings) {
  std::unordered_set<std::int64_t> utimes;
  if (input.corrected.empty()) {
    warnings->push_back("odometry map: no corrected trajectory, built from every scan");
    utimes.insert(input.scan_utimes.begin(), input.scan_utimes.end());
    return utimes;
  }
  const std::int32_t first = input.corrected.front().session;
  std::size_t other = 0;
  for (const auto& k : input.corrected) {
    if (k.session == first)
      utimes.insert(k.utime);
    else
      ++other;
  }
  if (other > 0) warnings->push_back("odometry map: " + std::to_string(other) + " keyframes of later sessions left out (their own odometry frames)");
  return utimes;
}

/// A warning when odometry and ground truth disagree at the first keyframe: maps are compared without alignment.
void check_frames(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& odometry, std::int64_t utime,
                  std::vector<std::string>* warnings) {
  const auto T_gt = pose_at(gt, utime), T_odom = pose_at(odometry, utime);
  if (!T_gt || !T_odom) return;
  const double d = (T_gt->translation() - T_odom->translation()).norm();
  if (d > kFrameWarning)
    warnings->push_back("odometry starts " + fmt(d, 2) + " m from ground truth: the maps are compared in ground truth's frame without alignment");
}

nlohmann::json opt(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); }
std::string opt_str(const std::optional<double>& v, int precision) { return v ? fmt(*v, precision) : "-"; }

}  // namespace

std::optional<std::string> MapEvalOptions::validate() const {
  if (!(voxel > 0.0) || !std::isfinite(voxel)) return "--map-voxel must be > 0 m";
  if (!(range > 0.0) || !std::isfinite(range)) return "--map-range must be > 0 m";
  if (!enabled() && (!map_cloud_odometry.empty() || !movers.empty())) return "--map-cloud-odometry and --movers need --map-cloud";
  return quality.validate();
}

void add_map_options(CLI::App& app, MapEvalOptions* o) {
  app.add_option("--map-cloud", o->map_cloud,
                 "map to judge (.pcd / .ply, in ground truth's world frame, e.g. from loopd-map export-cloud): its error against a "
                 "reference map built from the drive's own scans at the ground-truth poses")
      ->check(CLI::ExistingFile);
  app.add_option("--map-cloud-odometry", o->map_cloud_odometry,
                 "a map built from odometry (e.g. loopd-map export-cloud --odometry); default: built here from the keyframe scans")
      ->check(CLI::ExistingFile);
  app.add_option("--movers", o->movers, "loopd-sim's movers file (JSON boxes of the cars that moved): the moving-object points left in the maps")
      ->check(CLI::ExistingFile);
  app.add_option("--map-voxel", o->voxel, "[m] voxel leaf of the reference map and of the self-built odometry map")->capture_default_str();
  app.add_option("--map-range", o->range, "[m] scan points beyond this from the sensor are left out of those maps")->capture_default_str();
  app.add_option("--map-completeness-radius", o->quality.completeness_radius, "[m] a reference point is covered when a map point is this close")
      ->capture_default_str();
}

bool run_map_eval(const MapEvalOptions& options, const std::vector<std::string>& drives, const EvalChannels& channels, const EvalInput& input,
                  bool quiet, MapEvalReport* report, std::string* error) {
  if (!options.enabled()) return true;
  report->ran = true;
  PointCloud map, odometry_map;
  std::vector<MapMoverBox> movers;
  if (!read_map(options.map_cloud, &map, error)) return false;
  report->odometry_from_file = !options.map_cloud_odometry.empty();
  if (report->odometry_from_file && !read_map(options.map_cloud_odometry, &odometry_map, error)) return false;
  report->has_movers = !options.movers.empty();
  if (report->has_movers && !read_movers(options.movers, &movers, error)) return false;
  report->mover_boxes = static_cast<std::int64_t>(movers.size());

  MapBuilder reference(input.ground_truth, options.voxel, options.range), odometry(input.odometry, options.voxel, options.range);
  const std::unordered_set<std::int64_t> keyframes =
      report->odometry_from_file ? std::unordered_set<std::int64_t>{} : odometry_keyframes(input, &report->warnings);
  const ScanSink sink = [&](PointCloud&& cloud, std::int64_t utime) {
    if (keyframes.count(utime) > 0) odometry.add(cloud, utime);  // a copy: deskewed with odometry, not ground truth
    reference.add(std::move(cloud), utime);
  };
  if (!stream_scans(drives, channels, quiet, sink, &report->scans_malformed, error)) return false;
  const PointCloud reference_cloud = reference.voxels.cloud();
  if (reference_cloud.empty()) {
    *error = "map evaluation: no scan of the drive had a ground-truth pose (reference map empty)";
    return false;
  }
  report->reference_points = static_cast<std::int64_t>(reference_cloud.size());
  report->reference_scans = reference.scans;
  report->scans_deskewed = reference.deskewed;
  report->scans_without_pose = reference.without_pose;
  report->reference_moving_points = count_mover_points(reference_cloud, movers, options.quality.mover_margin);
  report->map = map_quality(map, reference_cloud, movers, options.quality);
  if (!report->odometry_from_file && odometry.scans > 0) odometry_map = odometry.voxels.cloud();
  report->odometry_scans = odometry.scans;
  if (report->odometry_from_file || odometry.scans > 0) report->odometry = map_quality(odometry_map, reference_cloud, movers, options.quality);
  if (!report->odometry) report->warnings.push_back("odometry map: no keyframe scan had an odometry pose");
  if (!input.corrected.empty()) check_frames(reference.poses, odometry.poses, input.corrected.front().utime, &report->warnings);
  if (report->scans_without_pose > 0)
    report->warnings.push_back(std::to_string(report->scans_without_pose) + " scans without ground truth left out of the reference map");
  return true;
}

void print_map_eval(const MapEvalReport& r) {
  if (!r.ran) return;
  const MapQuality empty;
  const MapQuality& o = r.odometry ? *r.odometry : empty;
  const std::string odo = r.odometry ? "" : "-";
  Table t({"map quality (against the reference)", "map", r.odometry_from_file ? "odometry map (file)" : "odometry map (keyframes)"});
  t.add({"points", std::to_string(r.map.points), odo.empty() ? std::to_string(o.points) : odo});
  t.add({"error to nearest reference point, mean [m]", opt_str(r.map.mean_error, 4), opt_str(o.mean_error, 4)});
  t.add({"error to nearest reference point, p95 [m]", opt_str(r.map.p95_error, 4), opt_str(o.p95_error, 4)});
  t.add({"completeness (reference points covered)", opt_str(r.map.completeness, 3), opt_str(o.completeness, 3)});
  if (r.has_movers)
    t.add({"moving-object points (share)", std::to_string(r.map.moving_points) + " (" + fmt(100.0 * r.map.moving_points_share, 2) + " %)",
           odo.empty() ? std::to_string(o.moving_points) + " (" + fmt(100.0 * o.moving_points_share, 2) + " %)" : odo});
  std::cout << t.str() << "reference map: " << r.reference_points << " voxels from " << r.reference_scans << " scans (" << r.scans_deskewed
            << " deskewed with ground truth)";
  if (!r.odometry_from_file) std::cout << "; odometry map from " << r.odometry_scans << " keyframe scans";
  if (r.has_movers) std::cout << "; " << r.reference_moving_points << " moving-object points in the reference (" << r.mover_boxes << " boxes)";
  std::cout << "\n\n";
}

void add_map_json(const MapEvalReport& r, nlohmann::json& j) {
  const bool movers = r.ran && r.has_movers;
  const std::optional<MapQuality>& o = r.odometry;
  j["map_error_m"] = r.ran ? opt(r.map.mean_error) : nlohmann::json(nullptr);
  j["map_error_p95_m"] = r.ran ? opt(r.map.p95_error) : nlohmann::json(nullptr);
  j["map_error_odometry_m"] = r.ran && o ? opt(o->mean_error) : nlohmann::json(nullptr);
  j["map_completeness"] = r.ran ? opt(r.map.completeness) : nlohmann::json(nullptr);
  j["map_points"] = r.ran ? nlohmann::json(r.map.points) : nlohmann::json(nullptr);
  j["map_reference_points"] = r.ran ? nlohmann::json(r.reference_points) : nlohmann::json(nullptr);
  j["map_moving_points"] = movers ? nlohmann::json(r.map.moving_points) : nlohmann::json(nullptr);
  j["map_moving_points_share"] = movers ? nlohmann::json(r.map.moving_points_share) : nlohmann::json(nullptr);
  j["map_moving_points_odometry_share"] = movers && o ? nlohmann::json(o->moving_points_share) : nlohmann::json(nullptr);
  j["reference_moving_points"] = movers ? nlohmann::json(r.reference_moving_points) : nlohmann::json(nullptr);
}

}  // namespace loopd::tools
