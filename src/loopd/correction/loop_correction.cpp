#include "loopd/correction/loop_correction.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace loopd {

std::optional<std::string> HeuristicCorrectionConfig::validate() const {
  if (!(min_weight_fraction >= 0.0)) return "min_weight_fraction must be >= 0";
  if (!(min_step_length >= 0.0)) return "min_step_length must be >= 0";
  if (!(closed_span_weight >= 0.0 && closed_span_weight <= 1.0)) return "closed_span_weight must be in [0, 1]";
  return std::nullopt;
}

std::vector<double> edge_weights(const std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& residuals,
                                 const HeuristicCorrectionConfig& config) {
  const std::size_t n = poses.size();
  std::vector<double> c(n, 0.0);
  if (n < 2) return c;
  // Vlaminck 2019, Sec. 4.4: c_ij grows with the scan-matching residual; unknown residuals -> equal weights.
  bool known = residuals.size() == n;
  double sum = 0.0;
  std::size_t positive = 0;
  if (known) {
    for (std::size_t i = 1; i < n; ++i) {
      const double r = residuals[i];
      if (std::isfinite(r) && r > 0.0) {
        sum += r;
        ++positive;
      }
    }
    known = positive > 0;
  }
  const double floor = known ? config.min_weight_fraction * sum / static_cast<double>(positive) : 0.0;
  for (std::size_t i = 1; i < n; ++i) {
    double w = 1.0;
    if (known) {
      const double r = residuals[i];
      w = std::max(std::isfinite(r) ? r : 0.0, floor);
      if (w <= 0.0) w = 1e-12;
    }
    if (config.distance_weighting) w *= (poses[i].translation() - poses[i - 1].translation()).norm() + config.min_step_length;
    c[i] = w;
  }
  return c;
}

HeuristicCorrectionResult apply_heuristic_correction(std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& weights,
                                                     const LoopConstraint& loop, bool rotate_positions) {
  HeuristicCorrectionResult result;
  const auto n = static_cast<PoseIndex>(poses.size());
  if (loop.query_index < 0 || loop.match_index < 0 || loop.query_index >= n || loop.match_index >= n) {
    result.reason = "loop index out of range";
    return result;
  }
  if (loop.query_index == loop.match_index) {
    result.reason = "zero-length loop (query == match)";
    return result;
  }
  const PoseIndex s = std::min(loop.query_index, loop.match_index);
  const PoseIndex e = std::max(loop.query_index, loop.match_index);
  result.start_index = s;
  result.end_index = e;
  // T_se: measured pose of V_e in V_s. The loop measurement itself is no error (Vlaminck 2019, Sec. 4.4: R_se is
  // discarded), so the error is what remains after it: D maps the drifted V_e onto V_s * T_se.
  const Eigen::Isometry3d T_se = (s == loop.match_index) ? loop.T_match_query : loop.T_match_query.inverse();
  const Eigen::Isometry3d target_e = poses[static_cast<std::size_t>(s)] * T_se;
  const Eigen::Isometry3d D = target_e * poses[static_cast<std::size_t>(e)].inverse();
  const Eigen::Quaterniond q_D(D.linear());
  const Eigen::AngleAxisd aa_D(q_D.normalized());
  // Rotation about c = position of V_s: D(x) = R_D (x - c) + c + u.
  const Eigen::Vector3d c = poses[static_cast<std::size_t>(s)].translation();
  const Eigen::Vector3d u = D.linear() * c + D.translation() - c;
  const Eigen::Vector3d end_shift = target_e.translation() - poses[static_cast<std::size_t>(e)].translation();
  result.correction_translation = (target_e.translation() - poses[static_cast<std::size_t>(e)].translation()).norm();
  result.correction_rotation = aa_D.angle();

  // d(V_s, V_e) = sum of c_ij on the path (Eq. 3 denominator).
  double total = 0.0;
  for (PoseIndex i = s + 1; i <= e; ++i) total += weights[static_cast<std::size_t>(i)];
  const bool equal = !(total > 0.0) || !std::isfinite(total);
  if (equal) total = static_cast<double>(e - s);

  const double angle = aa_D.angle();
  const Eigen::Vector3d axis = aa_D.axis();
  double d = 0.0;
  for (PoseIndex i = s + 1; i < e; ++i) {
    d += equal ? 1.0 : weights[static_cast<std::size_t>(i)];
    const double w = d / total;  // Eq. (3)
    // slerp(I, R_D, w) = rotation by w * angle about the same axis.
    const Eigen::Matrix3d R_w = Eigen::AngleAxisd(w * angle, axis).toRotationMatrix();
    Eigen::Isometry3d& P = poses[static_cast<std::size_t>(i)];
    P.translation() = rotate_positions ? Eigen::Vector3d(R_w * (P.translation() - c) + c + w * u) : Eigen::Vector3d(P.translation() + w * end_shift);
    P.linear() = R_w * P.linear();
  }
  // V_e gets exactly its target; everything after it moves rigidly with D.
  poses[static_cast<std::size_t>(e)] = target_e;
  for (PoseIndex i = e + 1; i < n; ++i) poses[static_cast<std::size_t>(i)] = D * poses[static_cast<std::size_t>(i)];
  // Keep rotations orthonormal after many corrections (the rigid tail only multiplies by D, already orthonormal).
  for (PoseIndex i = s + 1; i < e; ++i) {
    Eigen::Isometry3d& P = poses[static_cast<std::size_t>(i)];
    P.linear() = Eigen::Quaterniond(P.linear()).normalized().toRotationMatrix();
  }
  result.applied = true;
  return result;
}

std::vector<Eigen::Isometry3d> correct_heuristic(const std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& residuals,
                                                 const LoopConstraint& loop, const HeuristicCorrectionConfig& config) {
  std::vector<Eigen::Isometry3d> out = poses;
  apply_heuristic_correction(out, edge_weights(poses, residuals, config), loop, config.rotate_positions);
  return out;
}

HeuristicCorrectionResult apply_heuristic_with_spans(std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& base_weights,
                                                     const LoopConstraint& loop, std::vector<ClosedSpan>& closed_spans,
                                                     const HeuristicCorrectionConfig& config) {
  const auto n = static_cast<PoseIndex>(poses.size());
  const PoseIndex s = std::clamp(std::min(loop.query_index, loop.match_index), PoseIndex{0}, std::max(n - 1, PoseIndex{0}));
  const PoseIndex e = std::clamp(std::max(loop.query_index, loop.match_index), PoseIndex{0}, std::max(n - 1, PoseIndex{0}));
  std::vector<double> w = base_weights;
  w.resize(poses.size(), 1.0);
  if (config.closed_span_weight < 1.0 && !closed_spans.empty() && e > s) {
    // An edge (i-1, i) inside a closed span [a, b] (a < i <= b) keeps that loop closed when it takes no share.
    // How many spans cover each edge, by a difference array: O(spans + e - s), not O(spans * overlap) (every loop of
    // a long drive adds a span that may reach back to its first lap).
    std::vector<std::int64_t> covers(static_cast<std::size_t>(e - s + 2), 0);
    for (const auto& span : closed_spans) {
      const PoseIndex from = std::max(span.first + 1, s + 1), to = std::min(span.second, e);
      if (from > to) continue;
      covers[static_cast<std::size_t>(from - s)] += 1;
      covers[static_cast<std::size_t>(to - s + 1)] -= 1;
    }
    for (std::size_t k = 1; k < covers.size(); ++k) covers[k] += covers[k - 1];
    double free_total = 0.0;
    for (PoseIndex i = s + 1; i <= e; ++i)
      if (covers[static_cast<std::size_t>(i - s)] == 0) free_total += w[static_cast<std::size_t>(i)];
    if (free_total > 0.0)
      for (PoseIndex i = s + 1; i <= e; ++i)
        if (covers[static_cast<std::size_t>(i - s)] > 0) w[static_cast<std::size_t>(i)] *= config.closed_span_weight;
  }
  HeuristicCorrectionResult r = apply_heuristic_correction(poses, w, loop, config.rotate_positions);
  if (r.applied) closed_spans.emplace_back(r.start_index, r.end_index);
  return r;
}

std::vector<Eigen::Isometry3d> correct_heuristic_all(const std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& residuals,
                                                     const std::vector<LoopConstraint>& loops, const HeuristicCorrectionConfig& config) {
  std::vector<Eigen::Isometry3d> out = poses;
  const std::vector<double> base = edge_weights(poses, residuals, config);
  std::vector<const LoopConstraint*> order;
  order.reserve(loops.size());
  for (const auto& l : loops) order.push_back(&l);
  // Inside-out: by end index, then the shorter loop first.
  std::stable_sort(order.begin(), order.end(), [](const LoopConstraint* a, const LoopConstraint* b) {
    const PoseIndex ea = std::max(a->query_index, a->match_index), eb = std::max(b->query_index, b->match_index);
    if (ea != eb) return ea < eb;
    return std::min(a->query_index, a->match_index) > std::min(b->query_index, b->match_index);
  });
  std::vector<ClosedSpan> spans;
  for (const LoopConstraint* l : order) apply_heuristic_with_spans(out, base, *l, spans, config);
  return out;
}

}  // namespace loopd
