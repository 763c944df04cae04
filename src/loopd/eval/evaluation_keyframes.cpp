// The keyframe steps of evaluate(): frame numbers (Vlaminck 2019, 5.3), the evaluated keyframes and their poses.
#include <algorithm>
#include <iterator>
#include <optional>

#include "loopd/eval/evaluation_internal.hpp"
#include "loopd/eval/pose_error.hpp"

namespace loopd {
namespace detail {
namespace {

/// @brief The trajectory's typical keyframe spacing in frames: the median gap between its keyframes' frames (>= 1).
std::int64_t keyframe_spacing(const std::vector<KeyframePose>& corrected, const FrameIndex& frames) {
  std::vector<std::int64_t> kf_frames;
  for (const auto& k : corrected) kf_frames.push_back(frames.frame_of(k.utime));
  std::sort(kf_frames.begin(), kf_frames.end());
  std::vector<std::int64_t> gaps;
  for (std::size_t i = 1; i < kf_frames.size(); ++i)
    if (kf_frames[i] > kf_frames[i - 1]) gaps.push_back(kf_frames[i] - kf_frames[i - 1]);
  std::int64_t spacing = 1;
  if (!gaps.empty()) {
    std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
    spacing = std::max<std::int64_t>(1, gaps[gaps.size() / 2]);
  }
  return spacing;
}

/// @brief After the last revision (which does not list later keyframes), the scans at the trajectory's typical
/// keyframe spacing are keyframes too.
void add_keyframes_after_last_revision(const std::vector<KeyframePose>& corrected, const FrameIndex& frames, std::set<std::int64_t>& kf,
                                       std::vector<std::string>& warnings) {
  const std::int64_t spacing = keyframe_spacing(corrected, frames);
  std::int64_t last_kf_utime = 0;
  for (const auto& k : corrected) last_kf_utime = std::max(last_kf_utime, k.utime);
  int added = 0;
  for (std::int64_t f = frames.frame_of(last_kf_utime) + spacing; f < static_cast<std::int64_t>(frames.entries.size()); f += spacing) {
    // entries are sorted by utime, and frames are drive order, so entry f is frame f for increasing scans.
    const std::int64_t u = frames.entries[static_cast<std::size_t>(f)].first;
    if (u > last_kf_utime) {
      kf.insert(u);
      ++added;
    }
  }
  if (added > 0)
    warnings.push_back("the last trajectory revision ends before the drive: " + std::to_string(added) + " later scans taken as keyframes (every " +
                       std::to_string(spacing) + " scans)");
}

}  // namespace

/// @brief A copy of `poses` sorted by utime (stable: poses with equal stamps keep their order).
std::vector<StampedPose> sorted_by_time(const std::vector<StampedPose>& poses) {
  std::vector<StampedPose> sorted = poses;
  std::stable_sort(sorted.begin(), sorted.end(), [](const StampedPose& a, const StampedPose& b) { return a.utime < b.utime; });
  return sorted;
}

std::int64_t FrameIndex::frame_of(std::int64_t utime) const {
  auto it = std::lower_bound(entries.begin(), entries.end(), std::make_pair(utime, std::int64_t{-1}));
  if (it == entries.end()) return std::prev(it)->second;
  if (it != entries.begin() && utime - std::prev(it)->first < it->first - utime) return std::prev(it)->second;
  return it->second;
}

/// @brief Frames from the drive's scans, or from the ground-truth poses (`gt`, sorted) when the drive has no scans.
FrameIndex build_frame_index(const std::vector<std::int64_t>& scan_utimes, const std::vector<StampedPose>& gt, std::vector<std::string>& warnings) {
  FrameIndex index;
  if (!scan_utimes.empty()) {
    for (std::size_t i = 0; i < scan_utimes.size(); ++i) index.entries.emplace_back(scan_utimes[i], static_cast<std::int64_t>(i));
  } else {
    warnings.push_back("no scans in the drive: frames are counted on ground-truth poses");
    for (std::size_t i = 0; i < gt.size(); ++i) index.entries.emplace_back(gt[i].utime, static_cast<std::int64_t>(i));
  }
  std::sort(index.entries.begin(), index.entries.end());
  return index;
}

/// @brief Keyframes: the corrected trajectory's keyframes, the ends of every loop, and after the last revision the
/// scans at the trajectory's typical keyframe spacing; every scan when there is no corrected trajectory.
std::set<std::int64_t> select_keyframe_utimes(const EvalInput& in, const FrameIndex& frames, std::vector<std::string>& warnings) {
  std::set<std::int64_t> kf;
  for (const auto& k : in.corrected) kf.insert(k.utime);
  for (const auto& l : in.loops) {
    kf.insert(l.query_utime);
    kf.insert(l.match_utime);
  }
  if (!in.corrected.empty()) {
    add_keyframes_after_last_revision(in.corrected, frames, kf, warnings);
  } else {
    warnings.push_back(
        "no CORRECTED_TRAJECTORY in the results: every scan counts as a keyframe for recall, and "
        "'after' equals odometry");
    for (const auto& fi : frames.entries) kf.insert(fi.first);
  }
  return kf;
}

/// @brief The last trajectory revision as T_map_sensor stamped poses, sorted by utime.
std::vector<StampedPose> corrected_trajectory(const std::vector<KeyframePose>& keyframes) {
  std::vector<StampedPose> corrected;
  for (const auto& k : keyframes) {
    StampedPose p;
    p.utime = k.utime;
    p.T_world_sensor = k.T_map_sensor;
    corrected.push_back(p);
  }
  return sorted_by_time(corrected);
}

/// @brief Looks up ground truth, odometry and the corrected pose at every keyframe utime; keyframes without ground
/// truth or odometry are dropped (with a warning). Fills rep's keyframe_utimes, keyframe_frames and gt_keyframes.
RawKeyframePoses sample_keyframes(const std::set<std::int64_t>& kf, const SortedTrajectories& tr, const EvalInput& in, const FrameIndex& frames,
                                  const EvalConfig& config, EvalReport& rep) {
  const std::int64_t last_corrected = tr.corrected.empty() ? 0 : tr.corrected.back().utime;
  const std::int64_t gi = config.max_interpolation_gap_us, gn = config.max_nearest_gap_us;
  int no_gt = 0, no_odom = 0;
  RawKeyframePoses raw;
  for (std::int64_t u : kf) {
    const auto g = pose_at(tr.gt, u, gi, gn);
    if (!g) {
      ++no_gt;
      continue;
    }
    const auto o = pose_at(tr.odom, u, gi, gn);
    if (!o) {
      ++no_odom;
      continue;
    }
    std::optional<Eigen::Isometry3d> a;
    if (!tr.corrected.empty() && u <= last_corrected) a = pose_at(tr.corrected, u, gi, gn);
    if (!a) a = in.corrected.empty() ? *o : in.T_map_odom * *o;
    rep.keyframe_utimes.push_back(u);
    rep.keyframe_frames.push_back(frames.frame_of(u));
    rep.gt_keyframes.push_back(*g);
    raw.odom.push_back(*o);
    raw.after.push_back(*a);
  }
  if (no_gt > 0) rep.warnings.push_back(std::to_string(no_gt) + " keyframes without ground truth were dropped");
  if (no_odom > 0) rep.warnings.push_back(std::to_string(no_odom) + " keyframes without odometry were dropped");
  return raw;
}

/// @brief "Before" and "after" share the ground truth's frame by aligning their first keyframe to it.
void align_to_ground_truth(const RawKeyframePoses& raw, EvalReport& rep) {
  const Eigen::Isometry3d A_before = rep.gt_keyframes.front() * raw.odom.front().inverse();
  const Eigen::Isometry3d A_after = rep.gt_keyframes.front() * raw.after.front().inverse();
  for (std::size_t i = 0; i < raw.odom.size(); ++i) {
    rep.before_keyframes.push_back(A_before * raw.odom[i]);
    rep.after_keyframes.push_back(A_after * raw.after[i]);
  }
}

}  // namespace detail
}  // namespace loopd
