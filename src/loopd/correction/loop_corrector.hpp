#pragma once
// Keeps the keyframe trajectory and all accepted loops, and re-corrects on each new loop.
#include <Eigen/Geometry>
#include <cstdint>
#include <future>
#include <optional>
#include <string>
#include <vector>

#include "loopd/correction/loop_correction.hpp"
#include "loopd/correction/pose_graph.hpp"

namespace loopd {

/// @brief Which correction runs on a new loop.
enum class CorrectionMethod {
  kHeuristic,           ///< Vlaminck 2019, Sec. 4.4 only (O(n), well under 1 ms for 5000 poses)
  kGraph,               ///< pose graph from the previous corrected state (raw odometry for the first loop)
  kHeuristicThenGraph,  ///< heuristic warm start, then the pose graph (Ren 2019, Sec. 3.4.3) -- default
};
std::string to_string(CorrectionMethod method);
/// @brief "heuristic", "graph", "heuristic+graph" (also "heuristic_then_graph").
std::optional<CorrectionMethod> correction_method_from_string(const std::string& name);

/// @brief Settings of the LoopCorrector.
struct LoopCorrectorConfig {
  CorrectionMethod method = CorrectionMethod::kHeuristicThenGraph;
  HeuristicCorrectionConfig heuristic;
  PoseGraphConfig graph;
  /// heuristic+graph, online: the pose graph (whose cost grows with the trajectory) is re-solved at most once per
  /// max(graph_interval, graph_interval_fraction x keyframes) keyframes, so its share of the work stays flat on long
  /// drives; loops in between are closed by the heuristic alone and join the next solve. A loop the corrected map
  /// misses by more than graph_now_translation or graph_now_rotation_deg (typically the first loop of a revisit) is
  /// solved at once. 1 and 0: solve on every loop.
  int graph_interval = 5;
  double graph_interval_fraction = 0.02;
  double graph_now_translation = 1.0;   ///< [m]
  double graph_now_rotation_deg = 3.0;  ///< [deg]
  /// Information of the step that joins two odometry segments (add_segment_start), per axis: weak enough that loops
  /// alone place a segment (1e-6: sigma 1000 m / 1000 rad), strong enough to keep an unplaced segment's gauge fixed.
  double join_information = 1e-6;
  /// heuristic+graph, online: a due pose-graph solve runs on a thread of its own from a snapshot of the graph, and the
  /// corrections go on with the heuristic meanwhile; its result is applied when max(this, graph_apply_fraction x the
  /// snapshot's keyframes) more keyframes have been added (the solve's cost grows with the map, and so does the time it
  /// is given), waiting there if it has not finished, so a replay and a live run decide
  /// alike, or at solve_all(). The
  /// keyframes added since move with the snapshot's newest one, and the loops closed since are closed again on top of it
  /// by the heuristic. 0: the solve runs inside add_loop (the caller waits for it).
  int graph_apply_after = 0;
  /// ... or this share of the snapshot's keyframes, if more. The application closes again, on the solved poses, every
  /// loop closed meanwhile (each over its whole span, which on a route driven many times reaches back to the first
  /// lap), so the keyframe that applies it waits for work that grows with this share times the map: a short lag keeps
  /// that stall small, a long one gives the solve (on the CPU the pipeline leaves) more time.
  double graph_apply_fraction = 0.005;
  /// The background solve's thread runs at this nice value (0-19): it uses the CPU the pipeline leaves instead of taking
  /// a core from it for as long as it runs, which grows with the map. The result and when it is applied do not change.
  int graph_solve_nice = 19;
  std::optional<std::string> validate() const;
};

/// @brief What one re-correction did.
struct CorrectionResult {
  bool ok = false;
  std::string reason;  ///< why not ok, or solver message
  CorrectionMethod method = CorrectionMethod::kHeuristic;
  int num_loops = 0;        ///< loops in the graph
  double ms_heuristic = 0;  ///< [ms]
  double ms_graph = 0;      ///< [ms]
  int graph_iterations = 0;
  bool graph_converged = false;
  bool graph_solved = false;           ///< a pose-graph solve ran (not only the heuristic)
  bool graph_deferred = false;         ///< heuristic+graph: closed by the heuristic, the graph waits (graph_interval)
  double start_translation_error = 0;  ///< [m] loop-end mismatch of the new loop before correction
  double start_rotation_error = 0;     ///< [rad]
  double end_translation_error = 0;    ///< [m] loop-end mismatch of the new loop after correction
  double end_rotation_error = 0;       ///< [rad]
  /// The first keyframe whose corrected pose this correction may have changed (the poses before it are bit for bit
  /// what they were): the loop's older end + 1 for the heuristic, 0 for a pose-graph solve. Lets the callers update
  /// what depends on the poses (the gate's cells) for the moved keyframes only.
  PoseIndex moved_from = 0;
};

/// @brief What a LoopCorrector needs, besides its keyframes, loops and corrected poses, to continue exactly where it
/// stopped (after a restart from a map store).
struct CorrectorResumeState {
  std::vector<ClosedSpan> closed_spans;  ///< loops already closed (kept closed by later heuristic passes)
  PoseIndex max_end_index = -1;          ///< newest loop end
  PoseIndex last_graph_index = -1;       ///< newest loop end when the graph was last solved
  std::int64_t num_loops = 0;            ///< loops the state covers
  /// A pose-graph solve in flight (graph_apply_after > 0): its snapshot's sizes and start, so a resumed corrector
  /// starts the same solve again and applies it at the same keyframe.
  struct Pending {
    PoseIndex poses = 0;                  ///< keyframes in the snapshot
    std::int64_t loops = 0;               ///< loops in the snapshot
    std::int64_t planes = 0;              ///< plane observations in the snapshot
    std::int64_t spans = 0;               ///< closed spans when it started
    bool solve_again = false;             ///< a loop since then was due a solve: another starts when this one is applied
    std::vector<Eigen::Isometry3d> warm;  ///< the solve's starting poses (the heuristic's state when it started)
  };
  std::optional<Pending> pending;
};

/// @brief The state as bytes (little-endian, versioned) for a map store, and back; decode never throws.
std::vector<std::uint8_t> encode_resume_state(const CorrectorResumeState& state);
struct DecodedResumeState {
  bool ok = false;
  std::string error;
  CorrectorResumeState state;
};
DecodedResumeState decode_resume_state(const std::vector<std::uint8_t>& bytes);

/// @brief Holds odometry keyframe poses (+ residuals) and all accepted loops; every keyframe's corrected pose is
/// available after each loop, and any later odometry pose maps into the corrected frame with T_map_odom().
/// Not thread-safe; the daemon calls it from its worker.
class LoopCorrector {
 public:
  /// @throws std::invalid_argument when the config is invalid (configuration error, once at construction).
  explicit LoopCorrector(const LoopCorrectorConfig& config = {});

  /// @brief Appends a keyframe (odometry pose T_odom_sensor and the residual of the step ending at it, 0 = unknown).
  /// Its corrected pose is T_map_odom() * T_odom_sensor. Returns its index.
  PoseIndex add_keyframe(const Eigen::Isometry3d& T_odom_sensor, double residual = 0.0);
  /// @brief Same, with the information (base/information.hpp) of the odometry step ending here (e.g. from the covariance in
  /// pose_t); the graph then uses it instead of the residual-based sigma for that edge. Zero = unknown.
  PoseIndex add_keyframe(const Eigen::Isometry3d& T_odom_sensor, double residual, const Information6d& step_information);
  /// @brief Same, with the step from the previous keyframe measured by the scans (registration/keyframe_step.hpp):
  /// T_previous_this and its information replace the odometry's step in every correction, and the keyframe is placed
  /// by it (corrected previous * T_previous_this). The first keyframe has no step (it is added as by odometry).
  PoseIndex add_keyframe(const Eigen::Isometry3d& T_odom_sensor, double residual, const Information6d& step_information,
                         const Eigen::Isometry3d& T_previous_this);

  /// @brief Appends the first keyframe of a new odometry segment (another session, or the same drive after its
  /// odometry restarted): nothing is known about the step from the previous keyframe. T_odom_sensor must continue the
  /// previous keyframe's pose (the caller stitches the new frame on with zero motion), so the segment starts where the
  /// last one ended until a loop places it. The step then takes all of a loop's error in the heuristic (the segment
  /// moves rigidly), and the pose graph gives it the information `join_information` x identity (weak: ~1 km / rad).
  PoseIndex add_segment_start(const Eigen::Isometry3d& T_odom_sensor);
  /// @brief Positions that start a segment (add_segment_start), increasing.
  const std::vector<PoseIndex>& segment_starts() const { return segment_starts_; }

  /// @brief Stores the loop and re-corrects the whole trajectory. Zero-length loops and bad indices are rejected
  /// (ok = false, nothing changes); the same keyframe pair twice is accepted (the graph averages them).
  CorrectionResult add_loop(const LoopConstraint& loop);
  /// @brief Why add_loop() would refuse this loop (zero length, index out of range), or nothing when it would take it.
  std::optional<std::string> check_loop(const LoopConstraint& loop) const;

  /// @brief Adds a ground/roadway plane seen from a keyframe (Ren 2019, Sec. 3.4.2); used by the graph methods when
  /// config.graph.use_plane_constraints is set, from the next correction on.
  void add_plane_observation(const PlaneObservation& observation) { planes_.push_back(observation); }

  /// @brief Batch form (offline): stores all valid loops, then corrects once with recorrect_all(). Loops with bad
  /// indices or zero length are skipped and counted in `reason`.
  CorrectionResult add_loops(const std::vector<LoopConstraint>& loops);

  /// @brief Re-corrects from odometry with all loops (e.g. after changing the method).
  CorrectionResult recorrect_all();
  /// @brief `loops` in place of every loop held (a loop taken out, or one put back), then recorrect_all(): the result
  ///        is the correction of a run that had only these loops. Refused (nothing changes) when one does not fit.
  CorrectionResult replace_loops(std::vector<LoopConstraint> loops);
  /// @brief One pose-graph solve of every keyframe and loop from the current corrected state (the end of a run: the
  ///        loops heuristic+graph closed by the heuristic alone since the last solve join it, and so do the keyframes
  ///        added after the last loop). The heuristic method keeps its state (ok = false).
  CorrectionResult solve_all();
  /// @brief graph_apply_after > 0: the solve in flight, once graph_apply_after keyframes were added after it started
  ///        (or at once with `now`), applied to the current state (waiting for it). Nothing when none is due.
  std::optional<CorrectionResult> apply_graph(bool now = false);
  /// @brief A pose-graph solve is in flight.
  bool graph_pending() const { return pending_.has_value(); }

  const std::vector<Eigen::Isometry3d>& corrected_poses() const { return corrected_; }
  const std::vector<Eigen::Isometry3d>& odometry_poses() const { return odometry_; }
  /// @brief The trajectory the corrections start from: the odometry poses with every measured step (add_keyframe with
  ///        T_previous_this) in place of the odometry's; the odometry poses themselves while no step is measured.
  const std::vector<Eigen::Isometry3d>& chain_poses() const { return measured_.empty() ? odometry_ : measured_; }
  /// @brief Steps measured by the scans so far.
  std::int64_t measured_steps() const { return measured_steps_; }
  const std::vector<double>& residuals() const { return residuals_; }
  const std::vector<LoopConstraint>& loops() const { return loops_; }
  std::size_t size() const { return odometry_.size(); }
  const LoopCorrectorConfig& config() const { return config_; }

  /// @brief The state resume() needs besides keyframes, loops and corrected poses.
  CorrectorResumeState resume_state() const;
  /// @brief Continues where a stopped corrector was: its keyframes were added again (add_keyframe, same order), then
  /// this restores its first state.num_loops loops (`loops`) and its corrected poses without correcting anything.
  /// Refused (nothing changes) when the sizes or indices do not fit.
  std::optional<std::string> resume(const std::vector<LoopConstraint>& loops, const std::vector<Eigen::Isometry3d>& corrected,
                                    const CorrectorResumeState& state);

  /// @brief T_map_odom = corrected_last * odom_last^-1 (identity before any keyframe).
  Eigen::Isometry3d T_map_odom() const;
  /// @brief Any odometry pose (e.g. one received after the last keyframe) in the corrected frame.
  Eigen::Isometry3d to_map(const Eigen::Isometry3d& T_odom_sensor) const { return T_map_odom() * T_odom_sensor; }

 private:
  CorrectionResult run_graph(std::vector<Eigen::Isometry3d> warm, CorrectionResult r);
  /// Starts a solve of the first `snapshot.poses` keyframes, `snapshot.loops` loops and `snapshot.planes` planes.
  void start_graph(CorrectorResumeState::Pending snapshot);
  /// The graph as it stands, as the snapshot of a solve.
  CorrectorResumeState::Pending snapshot_now() const;
  /// Keyframes after a solve of `snapshot_poses` keyframes started until it is applied.
  int graph_apply_lag(PoseIndex snapshot_poses) const;
  /// Waits for the solve in flight and forgets it (the state is about to be rebuilt).
  void drop_pending();
  std::vector<double> heuristic_weights() const;

  LoopCorrectorConfig config_;
  std::vector<Eigen::Isometry3d> odometry_;
  std::vector<Eigen::Isometry3d> measured_;  ///< chain_poses(): empty until a step is measured
  std::int64_t measured_steps_ = 0;
  std::vector<double> residuals_;
  std::vector<Eigen::Isometry3d> corrected_;
  std::vector<LoopConstraint> loops_;
  std::vector<PlaneObservation> planes_;
  std::vector<Information6d> step_information_;  ///< empty until a keyframe brings one
  std::vector<ClosedSpan> closed_spans_;
  PoseIndex max_end_index_ = -1;
  PoseIndex last_graph_index_ = -1;  ///< newest loop end when the graph was last solved online
  std::vector<PoseIndex> segment_starts_;
  /// The solve in flight (graph_apply_after > 0) and its snapshot.
  struct InFlight {
    CorrectorResumeState::Pending snapshot;
    std::future<PoseGraphResult> result;
  };
  std::optional<InFlight> pending_;
};

}  // namespace loopd
