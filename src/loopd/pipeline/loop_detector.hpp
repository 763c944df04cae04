#pragma once
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "loopd/base/lidar_model.hpp"
#include "loopd/base/point_cloud.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/base/sensor_estimate.hpp"
#include "loopd/base/stopwatch.hpp"
#include "loopd/correction/loop_corrector.hpp"
#include "loopd/descriptor/m2dp.hpp"
#include "loopd/records/keyframe_record.hpp"
#include "loopd/pipeline/candidate_ranking.hpp"
#include "loopd/pipeline/distance_gate.hpp"
#include "loopd/pipeline/feature_cache.hpp"
#include "loopd/pipeline/global_loops.hpp"
#include "loopd/pipeline/keyframe_database.hpp"
#include "loopd/pipeline/keyframe_selector.hpp"
#include "loopd/pipeline/verification_decision.hpp"
#include "loopd/pipeline/place_density.hpp"
#include "loopd/pipeline/prepare_scan.hpp"
#include "loopd/pipeline/remote_keyframes.hpp"
#include "loopd/pipeline/session_frames.hpp"
#include "loopd/registration/keyframe_step.hpp"
#include "loopd/retrieval/place_index.hpp"
#include "loopd/verify/verify.hpp"

namespace loopd {

/// @brief Everything the loop detector can be tuned with; defaults from the papers where they give one.
struct LoopDetectorConfig {
  /// Stages run single-threaded inside the detector: the daemon parallelises over keyframes instead, and nested
  /// OpenMP teams on top of the worker pool would only oversubscribe the cores.
  LoopDetectorConfig() {
    m2dp.num_threads = 1;
    prepare.num_threads = 1;
    prepare.normal_k_neighbors = 10;
    verify.four_pcs.num_threads = 1;
    verify.gicp.num_threads = 1;
    correction.graph.num_threads = 1;
    // The pose-graph solve beside the sequential stage, applied 25 keyframes (3-8 s of driving) after it started, or
    // 0.5 % of the map's keyframes if more: on a long map it takes a second or more, and every scan behind it waited.
    // A 6x soak with 10 waited up to 0.36 s for solves of 1,000-3,000 keyframes (on the CPU the pipeline leaves).
    correction.graph_apply_after = 25;
  }
  /// Lidar model for the segmentation's range image: "auto" (read from each keyframe's scan, sensor_estimate.hpp), a
  /// preset (lidar_model_names()), or "custom" with sensor_elevations_deg.
  std::string sensor = "auto";
  std::vector<double> sensor_elevations_deg;  ///< [deg] "custom": the beams' elevations, ascending
  int sensor_columns = 1024;                  ///< "custom": columns per revolution
  KeyframeConfig keyframe;                    ///< Ren 2019 Sec. 3.3.2
  DistanceGateConfig gate;                    ///< Vlaminck 2019 Sec. 4, Ren 2019 Sec. 3.4.1
  M2dpConfig m2dp;                            ///< Vlaminck 2019 Sec. 4.1 (l=8, t=16, p=4, q=16)
  PrepareConfig prepare;                      ///< downsampling + segmentation of a keyframe
  VerifyConfig verify;                        ///< Vlaminck 2019 Sec. 4.2-4.3
  double max_descriptor_distance = 0.35;      ///< candidates above this M2DP distance are not verified
  /// [m] Scale from the scene: below this scene_scale() of the query's scan (a courtyard, rooms) the Hungarian cluster
  /// consistency needed falls in proportion, to no less than 60 % of verify.min_hungarian_consistency. Small scenes
  /// segment into many small, view-dependent clusters (furniture, clutter): correct handheld revisits score 0.25-0.34
  /// where car revisits score above 0.35. 0: off.
  double small_scene_scale = 30.0;
  int max_candidates_per_keyframe = 3;  ///< verified best first, at most this many per keyframe
  /// [deg] A gated loop's verified rotation may differ this much from the rotation the corrected map predicts between
  /// the two keyframes (odometry yaw drifts a few degrees per km). A self-similar place (a tunnel seen from its other
  /// end, a symmetric junction) aligns well turned by 90 or 180 deg: that is rejected at stage "prior".
  double max_prior_rotation_deg = 45.0;
  /// Within this many keyframes after an accepted loop the corrected map already knows where the query lies relative
  /// to its candidates: GICP starts from that relative pose and the global 4PCS search is skipped (it runs only when
  /// this guided check rejects). 0 = always run 4PCS (the paper's pipeline).
  int guided_window = 5;
  /// Verify the candidates of one keyframe concurrently (live: spare cores shorten the latency tail). Decisions do
  /// not depend on it: the first accepted candidate in rank order wins. The daemon turns it on in live mode only.
  bool parallel_candidates = false;
  /// [m] with correction.graph.use_plane_constraints: keyframes whose ground lies in the same cell of this size
  /// observe one roadway plane node (Ren 2019, Sec. 3.4.2); a town's ground is only locally planar.
  double plane_cell_size = 40.0;
  LoopCorrectorConfig correction;  ///< Vlaminck 2019 Sec. 4.4 / Ren 2019 Sec. 3.4.3
  /// Loops without a pose prior (across sessions, after odometry resets, beyond the gate); enabled = false keeps the
  /// paper's gate-only pipeline.
  GlobalRetrievalConfig retrieval;
  /// The step between consecutive keyframes measured by their scans, in place of the odometry's in the corrections.
  KeyframeStepConfig steps;
  std::optional<std::string> validate() const;
};

/// @brief The verification settings of a query whose scan has this scene_scale() (small_scene_scale applied; 0: as
/// configured). The detector verifies every candidate of the query with them; loopd-verify does the same by hand.
VerifyConfig verify_config_for_scene(const LoopDetectorConfig& config, double scene_scale);

/// @brief A keyframe as handed to the sequential stage.
struct KeyframeInput {
  KeyframeKey key;         ///< the engine numbers a session's keyframes from 0
  std::int64_t utime = 0;  ///< scan time [us]
  Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();
  double residual = 0.0;               ///< odometry residual accumulated since the previous keyframe [m]
  std::uint64_t scan_fingerprint = 0;  ///< KeyframeRecord::scan_fingerprint
  /// The scan is free of motion skew: deskewed, measured in an instant, or moving too little during its sweep to matter
  /// (KeyframeStepConfig::max_unskewed_motion). Only such a keyframe's step is measured by the scans (config.steps):
  /// two skewed scans register short (the simulated demo without point times: ATE 0.36 -> 0.84 m with steps).
  bool motion_compensated = false;
};

/// @brief A corrected trajectory, mirrored by trajectory_t.
struct CorrectionOutput {
  std::int64_t revision = 0;
  std::int64_t loop_event_id = 0;
  std::string method;
  bool graph_solved = false;                                     ///< a pose-graph solve made this revision (its memory was just freed)
  std::vector<KeyframeKey> keys;                                 ///< every keyframe, in the order they were added
  std::vector<std::int64_t> utimes;                              ///< [us] by keys
  std::vector<Eigen::Isometry3d> T_map_sensor;                   ///< corrected poses, by keys
  Eigen::Isometry3d T_map_odom = Eigen::Isometry3d::Identity();  ///< of the newest keyframe's session
  std::vector<SessionAlignment> sessions;                        ///< every session, by id
  CorrectorResumeState resume_state;                             ///< what a map store keeps to resume correcting from this revision
  /// The newest loop ledger entry (records/loop_ledger.hpp) whose revocations this revision honours (0: none known).
  std::int64_t ledger_seq = 0;
  double ms = 0.0;
};

/// @brief What one keyframe produced.
struct DetectorOutput {
  std::vector<LoopDecision> decisions;
  std::optional<CorrectionOutput> correction;
};

/// @brief Loop detection and correction over a stream of keyframes (Vlaminck 2019, Fig. 1):
///        distance gate -> M2DP ranking -> 4PCS -> GICP -> Hungarian -> correction, and (without a pose prior) place
///        retrieval over every keyframe -> the same verification -> agreement of the next keyframes -> correction.
///        compute_features() is thread-safe and may run on many workers; add_keyframe() must be called
///        in keyframe order from one thread at a time.
class LoopDetector {
 public:
  explicit LoopDetector(const LoopDetectorConfig& config);
  ~LoopDetector();

  /// @brief Descriptor + prepared scan of one keyframe (heavy, thread-safe).
  /// @param measured_layout the sensor as the scan showed it before deskew moved its points (estimate_sensor of the
  ///        scan as measured), used with a sensor preset for the layout note and the preset check: deskewed, a point's
  ///        elevation is seen from the sensor at the stamp, not from where it was measured, and the near rings spread
  ///        by degrees. Null: both come from `scan`. The preset, not the layout, is what the scan is prepared with.
  /// @param check_layout false: with a preset, the layout is not read at all (no note, no preset check; the features
  ///        are the same). Without a preset the layout is the model, read from every scan.
  KeyframeFeatures compute_features(const PointCloud& scan, const SensorEstimate* measured_layout = nullptr, bool check_layout = true) const;
  /// @brief A sensor preset is fixed (not "auto"): the scan's layout is only checked against it.
  bool has_sensor_preset() const { return model_.has_value(); }
  /// @brief Adds a keyframe. `features` may be null when the keyframe was shed under load: its pose still
  ///        enters the trajectory but it is neither a query nor a candidate.
  /// @param on_decided called with each decision as soon as it is made, before an accepted loop's correction runs
  ///        (so a loop event need not wait for the pose graph); the decisions are also in the returned output.
  /// @param on_placed called with the keyframe as stored and its map pose, before any decision (a map store commits
  ///        the keyframe before its decisions go out).
  DetectorOutput add_keyframe(const KeyframeInput& input, std::shared_ptr<const KeyframeFeatures> features,
                              const std::function<void(const LoopDecision&)>& on_decided = {},
                              const std::function<void(const KeyframeRecord&, const Eigen::Isometry3d& T_map_sensor)>& on_placed = {});

  // Resuming from a map store: the engine replays what the store holds, in the order it happened (each keyframe, then
  // the decisions its query made), and the detector ends in the state it had when it stopped. Nothing is verified.

  /// @brief A stored keyframe, placed again as add_keyframe() placed it.
  void restore_keyframe(const KeyframeRecord& record);
  /// @brief A stored decision of the newest restored keyframe, counted again; an accepted one becomes a loop edge again
  /// with `information` (its correction comes from resume_correction() or is made again by reapply_loop()), unless
  /// `revoked` (the loop ledger revoked it before the stored correction): then it is held aside as set_revoked_loops() holds it.
  void restore_decision(const LoopDecision& decision, const Information6d& information, bool revoked = false);
  /// @brief The stored correction made by the newest restored keyframe's accepted loop: every restored keyframe's
  /// corrected pose (by key) and the corrector's resumable state. Covers every accepted loop restored so far.
  std::optional<std::string> resume_correction(std::int64_t revision, const std::vector<KeyframeKey>& keys,
                                               const std::vector<Eigen::Isometry3d>& T_map_sensor, const CorrectorResumeState& state);
  /// @brief An accepted loop of the newest restored keyframe whose correction was not stored (stopped in between):
  /// the correction is made again, exactly as it was then.
  std::optional<CorrectionOutput> reapply_loop(const LoopDecision& decision, const Information6d& information);
  /// @brief The corrector's resumable state (what the engine stores with each correction).
  CorrectorResumeState corrector_state() const { return corrector_.resume_state(); }

  /// @brief The accepted loops an operator revoked (the map's loop ledger up to entry `ledger_seq`): each leaves the
  /// pose graph and every later correction, and a loop no longer named (restored) joins it again. When that changes
  /// which loops the graph holds, the whole graph is solved again from the chain (LoopCorrector::replace_loops): a new
  /// revision, method "ledger", the correction of a run without the revoked loops. `force`: solved again even when
  /// nothing changed (loopd-map correct). Loops to keyframes of other vehicles are not in this graph (the fleet's).
  std::optional<CorrectionOutput> set_revoked_loops(const std::set<std::int64_t>& event_ids, std::int64_t ledger_seq, bool force = false);
  /// @brief The loops set_revoked_loops() keeps out of the graph, and the ledger entry it was last told.
  std::size_t revoked_loops() const { return revoked_.size(); }
  std::int64_t ledger_seq() const { return ledger_seq_; }
  /// @brief Decisions a stop cut off (published, then removed from the map with their undecided query keyframe): when
  /// the same candidate (query scan time, match keyframe) is decided again it takes the same event id, and new ones
  /// number after every id published, so an event id never names two candidates.
  void expect_decisions(const std::vector<LoopDecision>& cut_off);

  /// @brief A keyframe of another vehicle's session (a fleet sharing one map), as that vehicle stored it: a candidate
  /// for this vehicle's prior-free loops, never in this pose sequence (pose in its own session's odometry frame). A
  /// loop to it links nothing here (the fleet's joint correction takes it); it is accepted once two loops of this
  /// session agree on where that session lies (as prior-free loops are confirmed), or one agrees with an earlier
  /// accepted loop's placement. Returns false when the key is already held.
  bool add_remote_keyframe(KeyframeRecord record);
  std::size_t remote_keyframes() const { return remote_.size(); }

  // Area-bounded maps (place_density.hpp): the engine asks which keyframes share a place and retires the redundant ones.

  /// @brief `key` as the retirement policy sees it (corrected pose, travel, accepted loops); nullopt when not held.
  std::optional<PlaceKeyframe> place_view(const KeyframeKey& key) const;
  /// @brief The keyframes still candidates (not retired, not shed) within `radius` (<= gate.max_radius) of `key`'s
  /// corrected position whose sessions share its map frame, `key` excluded, nearest first.
  std::vector<PlaceKeyframe> place_views_near(const KeyframeKey& key, double radius) const;
  /// @brief Retires `key`: its features leave memory, the place index and the gate, so it is never a candidate again;
  /// its pose stays in the pose sequence with its odometry steps and loops (the graph loses nothing) and in every
  /// trajectory published. False when it is not held or has no features (already retired, or shed).
  bool retire_keyframe(const KeyframeKey& key);
  std::size_t retired_keyframes() const { return retired_keyframes_; }

  /// @brief Reads a keyframe's prepared scan back from where it is kept (a map store); nullopt when it cannot.
  using PreparedLoader = std::function<std::optional<PreparedScan>(const KeyframeKey&)>;
  /// @brief Memory bounded by a cache: keyframes keep their descriptor in memory and their prepared scans (most of
  /// their bytes) only in an LRU cache of `cache_bytes`; a candidate's scan not in it is read with `load_prepared`
  /// (the caller stores every keyframe before its decisions). Decisions are the same as with everything in memory.
  void keep_features_in_store(std::size_t cache_bytes, PreparedLoader load_prepared);
  /// @brief Bytes of full keyframe features in the cache (0 without keep_features_in_store).
  std::size_t cached_feature_bytes() const;

  /// @brief The end of a run: every keyframe and loop in one pose-graph solve, when the last correction was not one
  ///        (heuristic+graph closed its loops by the heuristic alone) or keyframes came after it; nothing otherwise.
  ///        A new revision naming the newest accepted loop, method "final".
  std::optional<CorrectionOutput> final_correction();
  /// @brief Corrected pose of an odometry pose received after the newest keyframe (in its session's frame).
  Eigen::Isometry3d T_map_odom() const;
  /// @brief Where every session lies in the map now.
  std::vector<SessionAlignment> session_alignments() const;
  /// @brief Keyframes in the place index (global retrieval).
  std::size_t indexed_places() const { return places_.size(); }
  std::size_t num_keyframes() const;
  std::int64_t loops_accepted() const { return loops_accepted_; }
  std::int64_t loops_rejected() const { return loops_rejected_; }
  /// @brief Keyframe steps measured by the scans (config().steps), and those left to the odometry.
  std::int64_t steps_measured() const { return corrector_.measured_steps(); }
  std::int64_t steps_refused() const { return steps_refused_; }
  std::int64_t steps_skewed() const { return steps_skewed_; }  ///< not measured: the keyframe's scan may be skewed
  /// @brief Average bytes held per stored keyframe (descriptor + prepared scan + pose).
  std::size_t bytes_per_keyframe() const;
  std::string descriptor_device() const;
  const LoopDetectorConfig& config() const { return config_; }

 private:
  using DecisionCallback = std::function<void(const LoopDecision&)>;
  const KeyframeRecord& place_keyframe(const KeyframeInput& input, std::shared_ptr<const KeyframeFeatures> features,
                                       const Eigen::Isometry3d& T_map_query, const std::optional<MeasuredStep>& step);
  void add_ground_plane(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_query);
  /// The keyframe joins the corrector's pose sequence with its step from the previous keyframe: `stored` (a restored
  /// keyframe: what was measured when it was added, never measured again) or, when null, measured now from `features`;
  /// the step used goes to `*step`. Returns its map pose.
  Eigen::Isometry3d enter_pose_sequence(const KeyframeInput& input, const KeyframeFeatures* features, const std::optional<MeasuredStep>* stored,
                                        std::optional<MeasuredStep>* step);
  /// The step from the newest keyframe (same segment) to this one measured by their scans (config_.steps); nullopt when
  /// off, either has no prepared scan, or the registration is not believed.
  std::optional<MeasuredStep> measure_step(const KeyframeFeatures* features, const Eigen::Isometry3d& T_continuous_sensor);
  LoopDecision make_decision(const KeyframeRecord& query, const RankedCandidate& candidate, double radius);
  struct GatedOutcome {
    std::vector<GateCandidate> gated;   ///< every keyframe the gate let through
    std::vector<KeyframeKey> verified;  ///< those verified
    double radius = 0.0;
    bool accepted = false;
  };
  GatedOutcome close_gated(const KeyframeRecord& query, const Eigen::Isometry3d& T_map_query, DetectorOutput& out,
                           const DecisionCallback& on_decided);
  void close_prior_free(const KeyframeRecord& query, const Eigen::Isometry3d& T_map_query, const GatedOutcome& gated, DetectorOutput& out,
                        const DecisionCallback& on_decided);
  void compute_place_descriptors(const PointCloud& scan, KeyframeFeatures& f) const;
  std::vector<PlaceCandidate> retrieve_places(const KeyframeFeatures& query, const GatedOutcome& gated,
                                              const std::function<bool(const KeyframeKey&)>& accept) const;
  std::function<bool(const KeyframeKey&)> prior_free_filter(const KeyframeRecord& query, const GatedOutcome& gated) const;
  /// Rejects (accepted = false, reason "prior: ...") an accepted gated verification whose rotation is farther than
  /// max_prior_rotation_deg from the corrected map's relative pose.
  void check_prior_rotation(const KeyframeRecord& match, const Eigen::Isometry3d& T_map_query, VerifyResult* v) const;
  enum class RemoteOutcome { kRejected, kHeld, kAccepted };
  RemoteOutcome close_remote(const KeyframeRecord& query, const KeyframeFeatures& query_features, const Eigen::Isometry3d& T_map_query,
                             const PlaceCandidate& place, double radius, DetectorOutput& out, const DecisionCallback& on_decided);
  bool confirm_remote(const KeyframeRecord& match, const VerifyResult& verification, const Eigen::Isometry3d& T_map_query, LoopDecision& decision);
  bool confirm_prior_free_loop(const PriorFreeLoop& loop, LoopDecision& decision);
  static std::shared_ptr<const KeyframeFeatures> thinned(const KeyframeFeatures& features);
  bool confirm_prior_free(const KeyframeRecord& query, const KeyframeRecord& match, const VerifyResult& verification,
                          const Eigen::Isometry3d& T_map_query, LoopDecision& decision);
  const Eigen::Isometry3d& corrected(const KeyframeKey& key) const { return corrector_.corrected_poses()[static_cast<std::size_t>(pose_index(key))]; }
  void report(LoopDecision decision, DetectorOutput& out, const DecisionCallback& on_decided);
  void report_descriptor_rejection(const KeyframeRecord& query, const RankedCandidate& best, double radius, DetectorOutput& out,
                                   const DecisionCallback& on_decided);
  class CandidateVerifications;
  CandidateVerifications start_verifications(const KeyframeRecord& query, const std::vector<RankedCandidate>& ranked, std::size_t count,
                                             const Eigen::Isometry3d& T_map_query) const;
  std::optional<CorrectionOutput> close_loop(const KeyframeRecord& query, const RankedCandidate& match, const VerifyResult& verification,
                                             LoopDecision decision, DetectorOutput& out, const DecisionCallback& on_decided);
  CorrectionOutput correction_output(const CorrectionResult& result, std::int64_t loop_event_id, const Stopwatch& sw);
  std::shared_ptr<const KeyframeFeatures> full_features(const KeyframeRecord& keyframe) const;
  PoseIndex pose_index(const KeyframeKey& key) const { return pose_index_.at(key); }
  /// The gate's positions after a correction that moved the keyframes from pose `moved_from` on (its cost is the
  /// moved keyframes', not the map's).
  void update_gate(PoseIndex moved_from);
  bool guided(const KeyframeKey& query) const;
  LoopConstraint count_restored(const LoopDecision& decision, const Information6d& information);
  /// The retirement policy's view of a held keyframe (place_view).
  PlaceKeyframe view_of(const KeyframeRecord& record) const;
  /// A placed keyframe enters the gate at its map position; one without features (shed, retired) in no cell of it.
  void add_to_gate(const KeyframeRecord& keyframe, const Eigen::Vector3d& position);

  /// The verification settings for one query (small_scene_scale applied).
  VerifyConfig verify_config_for(const KeyframeRecord& query) const;
  LoopDetectorConfig config_;
  std::optional<LidarModel> model_;
  std::unique_ptr<M2dp> m2dp_;
  DistanceGate gate_;
  LoopCorrector corrector_;
  KeyframeDatabase keyframes_;
  std::unordered_map<KeyframeKey, PoseIndex, KeyframeKeyHash> pose_index_;  ///< position in corrector_'s pose sequence
  std::vector<PoseIndex> record_pose_index_;  ///< pose_index_ of keyframes_.records()[i] (and of the gate's entry i), increasing
  PoseIndex correction_moved_from_ = 0;       ///< CorrectionResult::moved_from of the newest correction_output()
  double travelled_ = 0.0;
  double travelled_at_last_loop_ = 0.0;
  std::int64_t next_event_id_ = 0;
  std::map<std::pair<std::int64_t, KeyframeKey>, std::int64_t> expected_event_ids_;  ///< (query utime, match) -> id
  std::int64_t revision_ = 0;
  std::int64_t last_correction_event_id_ = 0;  ///< loop event of the newest correction
  std::size_t keyframes_at_correction_ = 0;    ///< keyframes the newest correction covered
  bool correction_was_graph_ = false;          ///< the newest correction was a pose-graph solve
  std::int64_t loops_accepted_ = 0;
  std::int64_t loops_rejected_ = 0;
  std::int64_t steps_refused_ = 0;
  std::int64_t steps_skewed_ = 0;
  std::optional<KeyframeKey> last_accepted_;  ///< query of the newest accepted loop
  std::vector<LoopConstraint> restored_loops_;
  std::vector<std::int64_t> restored_events_;  ///< event ids of restored_loops_
  /// Event id of each loop in corrector_.loops(), in its order (set_revoked_loops finds the loops it takes out by them).
  std::vector<std::int64_t> loop_events_;
  std::map<std::int64_t, LoopConstraint> revoked_;  ///< accepted loops revoked by the ledger, by event id
  std::int64_t ledger_seq_ = 0;
  std::unordered_map<KeyframeKey, int, KeyframeKeyHash> loop_ends_;  ///< accepted loops each keyframe is an end of
  std::size_t retired_keyframes_ = 0;
  SessionFrames sessions_;               ///< sessions in the corrector's one pose sequence, and which loops tied them
  PlaceIndex places_;                    ///< every keyframe's place descriptor (global retrieval), remote ones too
  RemoteKeyframes remote_;               ///< other vehicles' keyframes (fleet)
  PriorFreeConfirmation confirmation_;   ///< the newest verified prior-free loop, until the next keyframes agree
  std::unique_ptr<FeatureCache> cache_;  ///< null: every keyframe keeps its full features in memory
  PreparedLoader load_prepared_;         ///< accepted loops restored, handed to the corrector by resume_correction()
};

}  // namespace loopd
