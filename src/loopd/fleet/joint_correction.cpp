#include "loopd/fleet/joint_correction.hpp"

#include <algorithm>
#include <map>
#include <unordered_map>

#include "loopd/base/stopwatch.hpp"

namespace loopd {
namespace {

/// @brief Which sessions loops connect (union-find over session ids).
class SessionGroups {
 public:
  SessionId find(SessionId s) {
    auto it = parent_.find(s);
    if (it == parent_.end() || it->second == s) return s;
    return it->second = find(it->second);
  }
  void join(SessionId a, SessionId b) {
    a = find(a), b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::map<SessionId, SessionId> parent_;
};

/// @brief The sessions in the order they are chained: breadth first from the map's session (the lowest id) along
/// the loops between sessions, then the rest in id order; so each session after the first follows one it is tied to.
std::vector<SessionId> chain_order(const std::vector<SessionId>& sessions, const std::vector<JointLoop>& loops) {
  std::map<SessionId, std::vector<SessionId>> neighbours;
  for (const JointLoop& l : loops)
    if (l.query.session != l.match.session) {
      neighbours[l.query.session].push_back(l.match.session);
      neighbours[l.match.session].push_back(l.query.session);
    }
  std::vector<SessionId> order;
  std::map<SessionId, bool> seen;
  for (const SessionId start : sessions) {
    if (seen[start]) continue;
    seen[start] = true;
    order.push_back(start);
    for (std::size_t head = order.size() - 1; head < order.size(); ++head)
      for (const SessionId next : neighbours[order[head]])
        if (!seen[next] && std::binary_search(sessions.begin(), sessions.end(), next)) {
          seen[next] = true;
          order.push_back(next);
        }
  }
  return order;
}

/// @brief Every session's alignment: anchored when loops connect it to `map_session`, T_map_session at its newest
/// keyframe (keyframes sorted by key).
std::vector<SessionAlignment> alignments(const std::vector<JointKeyframe>& keyframes, const JointCorrection& solved, SessionId map_session,
                                         SessionGroups& groups) {
  std::vector<SessionAlignment> out;
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    if (out.empty() || out.back().session != keyframes[i].key.session) {
      SessionAlignment a;
      a.session = keyframes[i].key.session;
      a.anchored = groups.find(a.session) == groups.find(map_session);
      out.push_back(a);
    }
    ++out.back().num_keyframes;
    if (out.back().anchored) out.back().T_map_session = solved.T_map_sensor[i] * keyframes[i].T_odom_sensor.inverse();
  }
  return out;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

/// @brief The same loop seen from its match: T_query_match, with the information carried over (loopd's order, a
/// right perturbation: delta' = -Ad(T_match_query) delta, so I' = Ad^-T I Ad^-1).
LoopConstraint reversed(const LoopConstraint& c) {
  LoopConstraint r = c;
  std::swap(r.query_index, r.match_index);
  r.T_match_query = c.T_match_query.inverse();
  Eigen::Matrix<double, 6, 6> adjoint = Eigen::Matrix<double, 6, 6>::Zero();
  const Eigen::Matrix3d R = c.T_match_query.linear();
  adjoint.topLeftCorner<3, 3>() = R;
  adjoint.topRightCorner<3, 3>() = skew(c.T_match_query.translation()) * R;
  adjoint.bottomRightCorner<3, 3>() = R;
  const Eigen::Matrix<double, 6, 6> inverse = adjoint.inverse();
  r.information = inverse.transpose() * c.information * inverse;
  return r;
}

}  // namespace

JointCorrection solve_joint_correction(std::vector<JointKeyframe> keyframes, const std::vector<JointLoop>& loops,
                                       const JointCorrectionConfig& config) {
  Stopwatch sw;
  JointCorrection out;
  std::sort(keyframes.begin(), keyframes.end(), [](const JointKeyframe& a, const JointKeyframe& b) { return a.key < b.key; });
  std::vector<SessionId> sessions;
  for (const JointKeyframe& k : keyframes)
    if (sessions.empty() || sessions.back() != k.key.session) sessions.push_back(k.key.session);
  if (sessions.empty()) {
    out.error = "no keyframes";
    return out;
  }
  std::map<SessionId, std::pair<std::size_t, std::size_t>> span;  // [first, last) in keyframes
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    auto [it, fresh] = span.emplace(keyframes[i].key.session, std::pair{i, i + 1});
    if (!fresh) it->second.second = i + 1;
  }

  // One pose sequence: the sessions chained (the map's session first), each keyframe placed by SessionFrames.
  LoopCorrector corrector(config.corrector);
  SessionFrames frames;
  std::unordered_map<KeyframeKey, PoseIndex, KeyframeKeyHash> index_of;
  for (const SessionId session : chain_order(sessions, loops))
    for (std::size_t i = span[session].first; i < span[session].second; ++i) {
      const JointKeyframe& k = keyframes[i];
      const SessionFrames::Placed placed = frames.place(k.key, k.T_odom_sensor);
      index_of[k.key] = placed.starts_segment ? corrector.add_segment_start(placed.T_continuous_sensor)
                                              : corrector.add_keyframe(placed.T_continuous_sensor, k.residual);
    }
  SessionGroups groups;
  std::vector<LoopConstraint> constraints;
  for (const JointLoop& l : loops) {
    const auto q = index_of.find(l.query), m = index_of.find(l.match);
    if (q == index_of.end() || m == index_of.end() || q->second == m->second) {
      ++out.loops_skipped;
      continue;
    }
    LoopConstraint c;
    c.query_index = q->second;
    c.match_index = m->second;
    c.T_match_query = l.T_match_query;
    c.information = l.information;
    c.robust = l.robust;
    // Along the one sequence a loop runs back from its query (the corrector's heuristic walks from match to query):
    // a vehicle that found a loop to a session chained after its own gives it the other way round.
    constraints.push_back(c.query_index > c.match_index ? c : reversed(c));
    groups.join(l.query.session, l.match.session);
  }
  // In the order they end along the sequence, as the online corrector met them.
  std::stable_sort(constraints.begin(), constraints.end(), [](const LoopConstraint& a, const LoopConstraint& b) {
    return std::max(a.query_index, a.match_index) < std::max(b.query_index, b.match_index);
  });
  out.loops_used = static_cast<std::int64_t>(constraints.size());
  // One at a time, as the detectors closed them (the heuristic's warm start, then the graph when due): the batch
  // heuristic over hundreds of overlapping loops gave the graph a start it could not solve from (NaN in Ceres).
  for (const LoopConstraint& c : constraints) corrector.add_loop(c);

  for (const JointKeyframe& k : keyframes) {
    out.keys.push_back(k.key);
    out.utimes.push_back(k.utime);
    out.T_map_sensor.push_back(corrector.corrected_poses()[static_cast<std::size_t>(index_of[k.key])]);
  }
  out.sessions = alignments(keyframes, out, sessions.front(), groups);
  out.ok = true;
  out.ms = sw.ms();
  return out;
}

}  // namespace loopd
