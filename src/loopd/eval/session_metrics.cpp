#include "loopd/eval/session_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <unordered_map>

#include "loopd/eval/pose_error.hpp"

namespace loopd {
namespace {

/// @brief Positions hashed into cubes of the search radius: the nearest point within the radius is in the 27 cubes
/// around the query.
class PointGrid {
 public:
  explicit PointGrid(double radius) : radius_(radius) {}

  void insert(const Eigen::Vector3d& p, std::size_t index) {
    cells_[key(cell_of(p))].push_back(index);
    points_.emplace(index, p);
  }

  /// @brief Index of the nearest inserted point within the radius of `p`, or nullopt.
  std::optional<std::size_t> nearest(const Eigen::Vector3d& p) const {
    const Eigen::Vector3i c = cell_of(p);
    std::optional<std::size_t> best;
    double best_d = radius_;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells_.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (const std::size_t i : it->second) {
            const double d = (points_.at(i) - p).norm();
            if (d <= best_d && (!best || d < best_d || i < *best)) {
              best = i;
              best_d = d;
            }
          }
        }
    return best;
  }

 private:
  Eigen::Vector3i cell_of(const Eigen::Vector3d& p) const { return (p / radius_).array().floor().cast<int>(); }
  static std::int64_t key(const Eigen::Vector3i& c) {
    const auto u = [](int v) { return static_cast<std::int64_t>(v) & 0x1fffff; };
    return (u(c.x()) << 42) | (u(c.y()) << 21) | u(c.z());
  }
  double radius_;
  std::unordered_map<std::int64_t, std::vector<std::size_t>> cells_;
  std::unordered_map<std::size_t, Eigen::Vector3d> points_;
};

double median(std::vector<double> v) { return error_stats(std::move(v)).median; }

/// @brief Median relative-pose error of the session's keyframes at or after `anchor_utime` that have an earlier
/// session's keyframe within the radius (the nearest one).
void fill_alignment_error(const std::vector<SessionKeyframe>& kfs, const std::vector<std::size_t>& session_kfs, std::int64_t anchor_utime,
                          const PointGrid& earlier, SessionStats& s) {
  std::vector<double> translation, rotation;
  for (const std::size_t qi : session_kfs) {
    const SessionKeyframe& q = kfs[qi];
    if (q.utime < anchor_utime) continue;
    const auto mi = earlier.nearest(q.T_world.translation());
    if (!mi) continue;
    const SessionKeyframe& m = kfs[*mi];
    const RelativeError e = relative_error(m.T_map.inverse() * q.T_map, m.T_world.inverse() * q.T_world);
    translation.push_back(e.translation);
    rotation.push_back(e.rotation_deg);
  }
  s.alignment_samples = static_cast<int>(translation.size());
  if (translation.empty()) return;
  s.alignment_error_m = median(translation);
  s.alignment_error_deg = median(rotation);
}

/// @brief Ground-truth path length in [from, to] over the steps whose end lies in the mapped area (`earlier`).
double mapped_path_length(const std::vector<StampedPose>& gt, std::int64_t from, std::int64_t to, const PointGrid& earlier) {
  const auto first = std::lower_bound(gt.begin(), gt.end(), from, [](const StampedPose& p, std::int64_t t) { return p.utime < t; });
  double length = 0;
  for (auto it = first; it != gt.end() && it->utime <= to; ++it) {
    if (it == first) continue;
    const Eigen::Vector3d& p = it->T_world_sensor.translation();
    if (earlier.nearest(p)) length += (p - std::prev(it)->T_world_sensor.translation()).norm();
  }
  return length;
}

/// @brief Session ids of the keyframes and anchors, and each session's keyframes in time order.
std::map<std::int32_t, std::vector<std::size_t>> keyframes_by_session(const std::vector<SessionKeyframe>& kfs,
                                                                      const std::vector<SessionAnchor>& anchors) {
  std::map<std::int32_t, std::vector<std::size_t>> by;
  for (const auto& a : anchors) by[a.session];
  for (std::size_t i = 0; i < kfs.size(); ++i) by[kfs[i].session].push_back(i);
  for (auto& [s, v] : by) std::stable_sort(v.begin(), v.end(), [&](std::size_t a, std::size_t b) { return kfs[a].utime < kfs[b].utime; });
  return by;
}

/// @brief The worst (largest) of a present value and an optional one.
void keep_worst(std::optional<double>& worst, const std::optional<double>& v) {
  if (v && (!worst || *v > *worst)) worst = v;
}

}  // namespace

SessionMetrics session_metrics(const std::vector<SessionKeyframe>& kfs, const std::vector<SessionLoop>& loops,
                               const std::vector<SessionAnchor>& anchors, const std::vector<StampedPose>& gt, const SessionMetricsConfig& config) {
  SessionMetrics out;
  const auto by_session = keyframes_by_session(kfs, anchors);
  std::map<std::int32_t, std::int64_t> anchor_utime;  // first accepted loop from the session to another one
  for (const auto& l : loops) {
    if (l.query_session == l.match_session) continue;
    ++out.inter_session_loops_accepted;
    if (l.correct) ++out.inter_session_loops_correct;
    auto [it, added] = anchor_utime.emplace(l.query_session, l.query_utime);
    if (!added) it->second = std::min(it->second, l.query_utime);
  }
  std::map<std::int32_t, bool> anchored_flag;
  for (const auto& a : anchors) anchored_flag[a.session] = a.anchored;
  out.sessions = static_cast<int>(by_session.size());
  PointGrid earlier(config.mapped_radius);  // keyframes of the sessions before the current one
  for (const auto& [id, session_kfs] : by_session) {
    SessionStats s;
    s.session = id;
    s.keyframes = static_cast<int>(session_kfs.size());
    s.first = id == by_session.begin()->first;
    if (!session_kfs.empty()) s.first_utime = kfs[session_kfs.front()].utime;
    const auto au = anchor_utime.find(id);
    if (au != anchor_utime.end()) s.anchor_utime = au->second;
    const auto af = anchored_flag.find(id);
    s.anchored = s.first || (af != anchored_flag.end() ? af->second : s.anchor_utime.has_value());
    if (!s.first && !session_kfs.empty()) {
      const std::int64_t last_utime = kfs[session_kfs.back()].utime;
      s.mapped_distance_m = mapped_path_length(gt, s.first_utime, last_utime, earlier);
      if (s.anchor_utime) s.distance_to_alignment_m = mapped_path_length(gt, s.first_utime, *s.anchor_utime, earlier);
      // Anchored by the trajectory but no inter-session loop in these results: every keyframe counts.
      const std::int64_t from = s.anchor_utime ? *s.anchor_utime : std::numeric_limits<std::int64_t>::min();
      if (s.anchored) fill_alignment_error(kfs, session_kfs, from, earlier, s);
    }
    if (!s.first) {
      ++(s.anchored ? out.sessions_aligned : out.sessions_unaligned);
      keep_worst(out.alignment_error_m, s.alignment_error_m);
      keep_worst(out.alignment_error_deg, s.alignment_error_deg);
      keep_worst(out.alignment_distance_m, s.distance_to_alignment_m);
    }
    for (const std::size_t i : session_kfs) earlier.insert(kfs[i].T_world.translation(), i);
    out.per_session.push_back(s);
  }
  return out;
}

}  // namespace loopd
