#include "loopd/correction/loop_corrector.hpp"

#include <algorithm>
#include <stdexcept>

#include "loopd/base/stopwatch.hpp"
#include "loopd/base/thread_priority.hpp"
#include "loopd/correction/trajectory_tools.hpp"

namespace loopd {
namespace {
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
}  // namespace

std::string to_string(CorrectionMethod method) {
  switch (method) {
    case CorrectionMethod::kHeuristic:
      return "heuristic";
    case CorrectionMethod::kGraph:
      return "graph";
    case CorrectionMethod::kHeuristicThenGraph:
      return "heuristic+graph";
  }
  return "unknown";
}

std::optional<CorrectionMethod> correction_method_from_string(const std::string& name) {
  if (name == "heuristic") return CorrectionMethod::kHeuristic;
  if (name == "graph") return CorrectionMethod::kGraph;
  if (name == "heuristic+graph" || name == "heuristic_then_graph") return CorrectionMethod::kHeuristicThenGraph;
  return std::nullopt;
}

std::optional<std::string> LoopCorrectorConfig::validate() const {
  if (auto e = heuristic.validate()) return "heuristic: " + *e;
  if (auto e = graph.validate()) return "graph: " + *e;
  if (graph_interval < 1) return "graph_interval must be >= 1";
  if (!(graph_interval_fraction >= 0.0 && graph_interval_fraction <= 1.0)) return "graph_interval_fraction must be in [0, 1]";
  if (!(graph_now_translation >= 0.0) || !(graph_now_rotation_deg >= 0.0)) return "graph_now_translation and graph_now_rotation_deg must be >= 0";
  if (!(join_information > 0.0 && join_information <= 1.0)) return "join_information must be in (0, 1]";
  if (graph_apply_after < 0) return "graph_apply_after must be >= 0";
  if (!(graph_apply_fraction >= 0.0 && graph_apply_fraction <= 1.0)) return "graph_apply_fraction must be in [0, 1]";
  if (graph_solve_nice < 0 || graph_solve_nice > 19) return "graph_solve_nice must be in [0, 19]";
  return std::nullopt;
}

LoopCorrector::LoopCorrector(const LoopCorrectorConfig& config) : config_(config) {
  if (auto e = config_.validate()) throw std::invalid_argument("LoopCorrectorConfig: " + *e);
}

Eigen::Isometry3d LoopCorrector::T_map_odom() const {
  if (odometry_.empty()) return Eigen::Isometry3d::Identity();
  return corrected_.back() * odometry_.back().inverse();
}

PoseIndex LoopCorrector::add_keyframe(const Eigen::Isometry3d& T_odom_sensor, double residual) {
  const Eigen::Isometry3d T_map_odom_now = T_map_odom();
  if (!measured_.empty()) measured_.push_back(measured_.back() * (odometry_.back().inverse() * T_odom_sensor));
  odometry_.push_back(T_odom_sensor);
  residuals_.push_back(residual);
  corrected_.push_back(T_map_odom_now * T_odom_sensor);
  if (!step_information_.empty()) step_information_.push_back(Information6d::Zero());
  return static_cast<PoseIndex>(odometry_.size()) - 1;
}

PoseIndex LoopCorrector::add_keyframe(const Eigen::Isometry3d& T_odom_sensor, double residual, const Information6d& step_information) {
  const PoseIndex index = add_keyframe(T_odom_sensor, residual);
  if (step_information.isZero(0.0)) return index;
  step_information_.resize(odometry_.size(), Information6d::Zero());
  step_information_.back() = step_information;
  return index;
}

PoseIndex LoopCorrector::add_keyframe(const Eigen::Isometry3d& T_odom_sensor, double residual, const Information6d& step_information,
                                      const Eigen::Isometry3d& T_previous_this) {
  const PoseIndex index = add_keyframe(T_odom_sensor, residual, step_information);
  if (index == 0) return index;
  const auto i = static_cast<std::size_t>(index);
  if (measured_.empty()) measured_ = odometry_;
  measured_[i] = measured_[i - 1] * T_previous_this;
  corrected_[i] = corrected_[i - 1] * T_previous_this;
  ++measured_steps_;
  return index;
}

PoseIndex LoopCorrector::add_segment_start(const Eigen::Isometry3d& T_odom_sensor) {
  const PoseIndex index = add_keyframe(T_odom_sensor, 0.0);
  if (index == 0) return index;  // the first keyframe starts the first segment anyway
  step_information_.resize(odometry_.size(), Information6d::Zero());
  step_information_.back() = Information6d::Identity() * config_.join_information;
  segment_starts_.push_back(index);
  return index;
}

std::vector<double> LoopCorrector::heuristic_weights() const {
  std::vector<double> weights = edge_weights(chain_poses(), residuals_, config_.heuristic);
  // A segment join takes (almost) all of a loop's error: the segment after it moves rigidly onto the loop.
  double total = 0.0;
  for (double w : weights) total += w;
  for (PoseIndex s : segment_starts_)
    if (s < static_cast<PoseIndex>(weights.size())) weights[static_cast<std::size_t>(s)] = std::max(total, 1.0) * 1e6;
  return weights;
}

CorrectionResult LoopCorrector::run_graph(std::vector<Eigen::Isometry3d> warm, CorrectionResult r) {
  const PoseGraphResult g = optimize_pose_graph(chain_poses(), residuals_, loops_, warm, config_.graph, planes_, step_information_, segment_starts_);
  r.ms_graph = g.ms;
  r.graph_iterations = g.iterations;
  r.graph_converged = g.converged;
  r.graph_solved = true;
  r.reason = g.message;
  if (g.poses.size() == odometry_.size()) corrected_ = g.poses;
  return r;
}

std::optional<std::string> LoopCorrector::check_loop(const LoopConstraint& loop) const {
  const auto n = static_cast<PoseIndex>(odometry_.size());
  if (loop.query_index < 0 || loop.match_index < 0 || loop.query_index >= n || loop.match_index >= n) return "loop index out of range";
  if (loop.query_index == loop.match_index) return "zero-length loop (query == match)";
  return std::nullopt;
}

CorrectionResult LoopCorrector::add_loop(const LoopConstraint& loop) {
  CorrectionResult r;
  r.method = config_.method;
  if (auto why = check_loop(loop)) {
    r.reason = *why;
    return r;
  }
  loops_.push_back(loop);
  r.num_loops = static_cast<int>(loops_.size());
  const PoseIndex e = std::max(loop.query_index, loop.match_index);
  if (e < max_end_index_) {
    // Out of order (offline use): the inside-out order of correct_heuristic_all needs a full pass.
    return recorrect_all();
  }
  max_end_index_ = e;

  Stopwatch watch;
  std::tie(r.start_translation_error, r.start_rotation_error) = loop_end_error(corrected_, loop);
  const bool far_off =
      r.start_translation_error > config_.graph_now_translation || r.start_rotation_error > config_.graph_now_rotation_deg * kDegToRad;
  const int interval = std::max(config_.graph_interval, static_cast<int>(config_.graph_interval_fraction * static_cast<double>(odometry_.size())));
  const bool graph_due = last_graph_index_ < 0 || e - last_graph_index_ >= interval || far_off;
  // Online case: apply the new loop to the current corrected state (in place: the heuristic moves only the loop's
  // keyframes and those after it); closed spans keep earlier loops closed.
  const PoseIndex s = std::min(loop.query_index, loop.match_index);
  if (config_.method != CorrectionMethod::kGraph)
    apply_heuristic_with_spans(corrected_, heuristic_weights(), loop, closed_spans_, config_.heuristic);
  else
    closed_spans_.emplace_back(s, e);
  r.moved_from = s + 1;
  r.ms_heuristic = watch.ms();
  if (config_.method == CorrectionMethod::kHeuristic) {
    r.reason = "heuristic";
  } else if (config_.method == CorrectionMethod::kHeuristicThenGraph && !graph_due) {
    r.method = CorrectionMethod::kHeuristic;
    r.graph_deferred = true;
    r.reason = "heuristic (graph deferred: solved " + std::to_string(e - last_graph_index_) + " keyframes ago)";
  } else if (config_.method == CorrectionMethod::kHeuristicThenGraph && config_.graph_apply_after > 0) {
    // The heuristic now; the solve on its own thread, applied graph_apply_after keyframes later (apply_graph).
    r.method = CorrectionMethod::kHeuristic;
    r.graph_deferred = true;
    last_graph_index_ = e;
    if (pending_) {
      pending_->snapshot.solve_again = true;
      r.reason = "heuristic (a pose-graph solve is running; another starts when it is applied)";
    } else {
      start_graph(snapshot_now());
      r.reason = "heuristic (pose graph solving in the background, applied " +
                 std::to_string(graph_apply_lag(static_cast<PoseIndex>(odometry_.size()))) + " keyframes later)";
    }
  } else {
    r = run_graph(corrected_, r);
    r.moved_from = 0;
    last_graph_index_ = e;
  }
  r.ok = true;
  std::tie(r.end_translation_error, r.end_rotation_error) = loop_end_error(corrected_, loop);
  return r;
}

void LoopCorrector::start_graph(CorrectorResumeState::Pending snapshot) {
  const auto n = static_cast<std::size_t>(snapshot.poses);
  const std::vector<Eigen::Isometry3d>& chain = chain_poses();
  std::vector<Eigen::Isometry3d> poses(chain.begin(), chain.begin() + static_cast<std::ptrdiff_t>(n));
  std::vector<double> residuals(residuals_.begin(), residuals_.begin() + static_cast<std::ptrdiff_t>(n));
  std::vector<LoopConstraint> loops(loops_.begin(), loops_.begin() + snapshot.loops);
  std::vector<PlaneObservation> planes(planes_.begin(), planes_.begin() + snapshot.planes);
  std::vector<Information6d> information;
  if (!step_information_.empty()) information.assign(step_information_.begin(), step_information_.begin() + static_cast<std::ptrdiff_t>(n));
  std::vector<PoseIndex> starts;
  for (PoseIndex s : segment_starts_)
    if (s < snapshot.poses) starts.push_back(s);
  InFlight f;
  f.result = std::async(std::launch::async, [poses = std::move(poses), residuals = std::move(residuals), loops = std::move(loops),
                                             warm = snapshot.warm, graph = config_.graph, planes = std::move(planes),
                                             information = std::move(information), starts = std::move(starts), nice = config_.graph_solve_nice] {
    if (nice > 0) lower_this_thread_priority(nice);
    return optimize_pose_graph(poses, residuals, loops, warm, graph, planes, information, starts);
  });
  f.snapshot = std::move(snapshot);
  pending_ = std::move(f);
}

CorrectorResumeState::Pending LoopCorrector::snapshot_now() const {
  return {static_cast<PoseIndex>(odometry_.size()),
          static_cast<std::int64_t>(loops_.size()),
          static_cast<std::int64_t>(planes_.size()),
          static_cast<std::int64_t>(closed_spans_.size()),
          false,
          corrected_};
}

int LoopCorrector::graph_apply_lag(PoseIndex snapshot_poses) const {
  return std::max(config_.graph_apply_after, static_cast<int>(config_.graph_apply_fraction * static_cast<double>(snapshot_poses)));
}

void LoopCorrector::drop_pending() {
  if (!pending_) return;
  pending_->result.wait();
  pending_.reset();
}

std::optional<CorrectionResult> LoopCorrector::apply_graph(bool now) {
  if (!pending_) return std::nullopt;
  const CorrectorResumeState::Pending& snapshot = pending_->snapshot;
  if (!now && static_cast<PoseIndex>(odometry_.size()) - snapshot.poses < graph_apply_lag(snapshot.poses)) return std::nullopt;
  const PoseGraphResult g = pending_->result.get();
  const CorrectorResumeState::Pending done = std::move(pending_->snapshot);
  pending_.reset();
  CorrectionResult r;
  r.method = CorrectionMethod::kGraph;
  r.num_loops = static_cast<int>(loops_.size());
  r.ms_graph = g.ms;
  r.graph_iterations = g.iterations;
  r.graph_converged = g.converged;
  r.graph_solved = true;
  r.reason = g.message;
  const auto n = static_cast<std::size_t>(done.poses);
  if (g.poses.size() == n && n > 0) {
    // The keyframes added since move with the snapshot's newest one; the loops closed since close again on top.
    std::vector<Eigen::Isometry3d> poses = corrected_;
    std::vector<ClosedSpan> spans(closed_spans_.begin(), closed_spans_.begin() + done.spans);
    const Eigen::Isometry3d T_solved_heuristic = g.poses.back() * poses[n - 1].inverse();
    for (std::size_t i = 0; i < n; ++i) poses[i] = g.poses[i];
    for (std::size_t i = n; i < poses.size(); ++i) poses[i] = T_solved_heuristic * poses[i];
    const std::vector<double> base = heuristic_weights();
    for (std::size_t k = static_cast<std::size_t>(done.loops); k < loops_.size(); ++k)
      apply_heuristic_with_spans(poses, base, loops_[k], spans, config_.heuristic);
    if (std::all_of(poses.begin(), poses.end(), [](const Eigen::Isometry3d& T) { return T.matrix().allFinite(); })) {
      corrected_ = std::move(poses);
      closed_spans_ = std::move(spans);
    } else {
      r.reason = "not applied: the solve and the loops since gave non-finite poses (" + r.reason + ")";
    }
  }
  // Loops closed since then by the heuristic alone are not in this solve.
  r.graph_deferred = static_cast<std::size_t>(done.loops) < loops_.size();
  if (done.solve_again) {
    last_graph_index_ = max_end_index_;
    start_graph(snapshot_now());
  }
  r.ok = true;
  if (!loops_.empty()) std::tie(r.end_translation_error, r.end_rotation_error) = loop_end_error(corrected_, loops_.back());
  return r;
}

CorrectionResult LoopCorrector::add_loops(const std::vector<LoopConstraint>& loops) {
  const auto n = static_cast<PoseIndex>(odometry_.size());
  int skipped = 0;
  for (const LoopConstraint& l : loops) {
    if (l.query_index < 0 || l.match_index < 0 || l.query_index >= n || l.match_index >= n || l.query_index == l.match_index) {
      ++skipped;
      continue;
    }
    loops_.push_back(l);
  }
  CorrectionResult r = recorrect_all();
  if (skipped) r.reason = std::to_string(skipped) + " loop(s) skipped (zero length or index out of range); " + r.reason;
  return r;
}

CorrectionResult LoopCorrector::solve_all() {
  apply_graph(true);  // the solve in flight first: a nearer start for the last one
  drop_pending();     // (and not another one it started)
  CorrectionResult r;
  r.method = CorrectionMethod::kGraph;
  r.num_loops = static_cast<int>(loops_.size());
  if (config_.method == CorrectionMethod::kHeuristic || loops_.empty()) {
    r.reason = loops_.empty() ? "no loops" : "heuristic method: no graph";
    return r;
  }
  r = run_graph(corrected_, r);
  last_graph_index_ = max_end_index_;
  r.ok = true;
  std::tie(r.end_translation_error, r.end_rotation_error) = loop_end_error(corrected_, loops_.back());
  return r;
}

CorrectionResult LoopCorrector::replace_loops(std::vector<LoopConstraint> loops) {
  for (const LoopConstraint& l : loops)
    if (auto why = check_loop(l)) {
      CorrectionResult r;
      r.method = config_.method;
      r.reason = *why;
      return r;
    }
  drop_pending();
  loops_ = std::move(loops);
  return recorrect_all();
}

CorrectionResult LoopCorrector::recorrect_all() {
  drop_pending();  // everything is solved again from the chain
  CorrectionResult r;
  r.method = config_.method;
  r.num_loops = static_cast<int>(loops_.size());
  Stopwatch watch;
  std::vector<Eigen::Isometry3d> warm = chain_poses();
  closed_spans_.clear();
  max_end_index_ = -1;
  for (const auto& l : loops_) {
    max_end_index_ = std::max(max_end_index_, std::max(l.query_index, l.match_index));
    closed_spans_.emplace_back(std::min(l.query_index, l.match_index), std::max(l.query_index, l.match_index));
  }
  if (config_.method != CorrectionMethod::kGraph) warm = correct_heuristic_all(chain_poses(), residuals_, loops_, config_.heuristic);
  r.ms_heuristic = watch.ms();
  if (config_.method == CorrectionMethod::kHeuristic) {
    corrected_ = std::move(warm);
    r.reason = "heuristic";
  } else {
    r = run_graph(std::move(warm), r);
    last_graph_index_ = max_end_index_;
  }
  r.ok = true;
  if (!loops_.empty()) std::tie(r.end_translation_error, r.end_rotation_error) = loop_end_error(corrected_, loops_.back());
  return r;
}

}  // namespace loopd
