#include "loopd/pipeline/loop_detector.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <future>
#include <map>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/scene_scale.hpp"
#include "loopd/base/stopwatch.hpp"

namespace loopd {

std::optional<std::string> LoopDetectorConfig::validate() const {
  if (auto e = validate_sensor_choice(sensor, sensor_elevations_deg, sensor_columns)) return e;
  if (auto e = keyframe.validate()) return e;
  if (auto e = gate.validate()) return e;
  if (auto e = m2dp.validate()) return "m2dp: " + *e;
  if (auto e = verify.validate()) return "verify: " + *e;
  if (auto e = correction.validate()) return "correction: " + *e;
  if (auto e = steps.validate()) return "steps: " + *e;
  if (!(max_descriptor_distance > 0.0)) return "max_descriptor_distance must be > 0";
  if (!(small_scene_scale >= 0.0 && std::isfinite(small_scene_scale))) return "verify.small_scene_scale must be >= 0 [m]";
  if (!(max_prior_rotation_deg > 0.0 && max_prior_rotation_deg <= 180.0)) return "verify.max_prior_rotation_deg must be in (0, 180]";
  if (max_candidates_per_keyframe < 1) return "max_candidates_per_keyframe must be >= 1";
  if (guided_window < 0) return "guided_window must be >= 0";
  if (!(plane_cell_size >= 1e-3)) return "plane_cell_size must be >= 0.001 [m]";  // cell indices stay in int64 range
  if (auto e = retrieval.validate()) return e;
  return std::nullopt;
}

LoopDetector::LoopDetector(const LoopDetectorConfig& config)
    : config_(config),
      model_(sensor_model_from_choice(config.sensor, config.sensor_elevations_deg, config.sensor_columns)),
      m2dp_(std::make_unique<M2dp>(config.m2dp)),
      gate_(config.gate),
      corrector_(config.correction),
      confirmation_(config.retrieval) {}

LoopDetector::~LoopDetector() = default;

KeyframeFeatures LoopDetector::compute_features(const PointCloud& scan, const SensorEstimate* measured_layout, bool check_layout) const {
  KeyframeFeatures f;
  f.input_points = scan.size();
  std::size_t removed = 0;
  for (const Eigen::Vector3f& p : scan.points) removed += p.allFinite() ? 0u : 1u;
  f.invalid_points = removed;
  // Copy the finite points only when there are others (a clean scan, the usual case, is used as it is).
  PointCloud filtered;
  if (removed > 0) filtered = remove_non_finite(scan);
  const PointCloud& clean = removed > 0 ? filtered : scan;
  if (clean.size() < 100) {
    f.error = "scan has " + std::to_string(clean.size()) + " finite points (need >= 100)";
    return f;
  }
  Stopwatch sw;
  M2dpResult d = m2dp_->compute(clean);
  f.ms_descriptor = sw.ms();
  if (!d.ok) {
    f.error = "descriptor: " + d.error;
    return f;
  }
  f.descriptor = std::move(d.descriptor);
  if (config_.retrieval.enabled) compute_place_descriptors(clean, f);
  f.ms_descriptor = sw.ms();
  sw.reset();
  // The range image's rings: read from this scan ("auto"), or the preset, checked against what the scan shows.
  f.scene_scale = static_cast<float>(scene_scale(clean));
  SensorEstimate seen;
  const LidarModel* model = nullptr;
  if (model_ && (measured_layout != nullptr || !check_layout)) {
    if (measured_layout) seen = *measured_layout;
    model = &*model_;
  } else {
    model = model_for_scan(model_, clean, &seen);
  }
  if (!model_ || measured_layout != nullptr || check_layout) {
    f.sensor_layout = seen.describe();
    if (model_) f.sensor_mismatch = preset_mismatch(*model_, seen).value_or("");
  }
  f.prepared = prepare_scan(clean, model, config_.prepare);
  f.ms_prepare = sw.ms();
  f.ok = true;
  return f;
}

void LoopDetector::compute_place_descriptors(const PointCloud& scan, KeyframeFeatures& f) const {
  f.place = compute_place_descriptor(scan, config_.retrieval.descriptor);
  const double shift = config_.retrieval.lateral_shift;
  if (!f.place.ok || shift <= 0.0) return;
  for (const float side : {-1.f, 1.f}) {  // the scan as seen from `shift` metres to either side (sensor y axis)
    PlaceDescriptor d = compute_place_descriptor(scan, config_.retrieval.descriptor, Eigen::Vector2f(0.f, side * static_cast<float>(shift)));
    if (d.ok) f.place_shifted.push_back(std::move(d));
  }
}

/// @brief The verifications of one keyframe's candidates, best first. Live mode starts the others concurrently
/// (spare cores cut the latency tail); the decision is the same either way: the first accepted candidate in rank
/// order wins and later ones are not reported. Reads nothing that changes while it runs (guesses are made up front).
class LoopDetector::CandidateVerifications {
 public:
  using Features = std::shared_ptr<const KeyframeFeatures>;
  CandidateVerifications(Features query, std::vector<Features> matches, std::vector<std::optional<Eigen::Isometry3d>> guesses,
                         const VerifyConfig& config, bool concurrent)
      : query_(std::move(query)), matches_(std::move(matches)), guesses_(std::move(guesses)), config_(config), pending_(matches_.size()) {
    if (!concurrent) return;
    for (std::size_t i = 1; i < matches_.size(); ++i) pending_[i] = std::async(std::launch::async, [this, i] { return run(i); });
  }
  CandidateVerifications(const CandidateVerifications&) = delete;  // the concurrent ones hold `this`
  CandidateVerifications& operator=(const CandidateVerifications&) = delete;
  /// @brief The verification of candidate i (waits for it, or runs it now).
  VerifyResult get(std::size_t i) { return pending_[i].valid() ? pending_[i].get() : run(i); }

 private:
  VerifyResult run(std::size_t i) const {
    if (!query_ || !matches_[i]) {
      VerifyResult unreadable;
      unreadable.reason = "the keyframe's features could not be read back from the map store";
      return unreadable;
    }
    return verify_candidate(query_->prepared, matches_[i]->prepared, guesses_[i], config_);
  }

  Features query_;  ///< held: a cache eviction while the verifications run frees nothing they use
  std::vector<Features> matches_;
  std::vector<std::optional<Eigen::Isometry3d>> guesses_;
  const VerifyConfig config_;  // a copy: the query's own settings (verify_config_for)
  std::vector<std::future<VerifyResult>> pending_;
};

LoopDetector::CandidateVerifications LoopDetector::start_verifications(const KeyframeRecord& query, const std::vector<RankedCandidate>& ranked,
                                                                       std::size_t count, const Eigen::Isometry3d& T_map_query) const {
  // Right after an accepted loop the corrected map is locally consistent: its relative pose is the guess.
  const bool from_map = guided(query.key);
  std::vector<CandidateVerifications::Features> matches;
  std::vector<std::optional<Eigen::Isometry3d>> guesses;
  for (std::size_t i = 0; i < count; ++i) {
    const KeyframeRecord& match = *ranked[i].match;
    matches.push_back(full_features(match));
    if (from_map)
      guesses.emplace_back(corrector_.corrected_poses()[static_cast<std::size_t>(pose_index(match.key))].inverse() * T_map_query);
    else
      guesses.emplace_back(std::nullopt);
  }
  return {full_features(query), std::move(matches), std::move(guesses), verify_config_for(query), config_.parallel_candidates && !from_map};
}

VerifyConfig LoopDetector::verify_config_for(const KeyframeRecord& query) const {
  return verify_config_for_scene(config_, query.features ? query.features->scene_scale : 0.0);
}

VerifyConfig verify_config_for_scene(const LoopDetectorConfig& config, double scene_scale) {
  VerifyConfig v = config.verify;
  if (config.small_scene_scale > 0.0 && scene_scale > 0.0 && scene_scale < config.small_scene_scale)
    v.min_hungarian_consistency *= std::max(0.6, scene_scale / config.small_scene_scale);
  return v;
}

std::shared_ptr<const KeyframeFeatures> LoopDetector::full_features(const KeyframeRecord& keyframe) const {
  if (!keyframe.features || !keyframe.features->prepared_in_store) return keyframe.features;
  if (auto cached = cache_->get(keyframe.key)) return cached;
  std::optional<PreparedScan> prepared = load_prepared_(keyframe.key);
  if (!prepared) return nullptr;
  auto full = std::make_shared<KeyframeFeatures>(*keyframe.features);
  full->prepared = std::move(*prepared);
  full->prepared_in_store = false;
  cache_->put(keyframe.key, full);
  return full;
}

void LoopDetector::keep_features_in_store(std::size_t cache_bytes, PreparedLoader load_prepared) {
  cache_ = std::make_unique<FeatureCache>(cache_bytes);
  load_prepared_ = std::move(load_prepared);
}

std::size_t LoopDetector::cached_feature_bytes() const { return cache_ ? cache_->bytes() : 0; }

const KeyframeRecord& LoopDetector::place_keyframe(const KeyframeInput& input, std::shared_ptr<const KeyframeFeatures> features,
                                                   const Eigen::Isometry3d& T_map_query, const std::optional<MeasuredStep>& step) {
  KeyframeRecord record;
  record.key = input.key;
  record.utime = input.utime;
  record.T_odom_sensor = input.T_odom_sensor;
  record.residual = input.residual;
  record.scan_fingerprint = input.scan_fingerprint;
  record.step = step;
  record.travelled = travelled_;
  record.features = std::move(features);
  if (record.features && config_.correction.graph.use_plane_constraints) add_ground_plane(record, T_map_query);
  // The place index keeps the place descriptor (the query itself is never its own candidate: index gap).
  const bool indexed = config_.retrieval.enabled && record.features && record.features->place.ok && places_.add(record.key, record.features->place);
  if (cache_ && record.features && (!record.features->prepared_in_store || indexed)) {
    // The map store holds the prepared scan: memory keeps the M2DP descriptor, the cache the newest full features.
    if (!record.features->prepared_in_store) cache_->put(record.key, record.features);
    record.features = thinned(*record.features);
  }
  record_pose_index_.push_back(pose_index(record.key));
  return keyframes_.add(std::move(record));
}

void LoopDetector::update_gate(PoseIndex moved_from) {
  const std::vector<Eigen::Isometry3d>& poses = corrector_.corrected_poses();
  if (gate_.size() != record_pose_index_.size()) {  // not one entry per keyframe record (not expected): every entry by key
    gate_.update_positions([this, &poses](const KeyframeKey& k) { return poses[static_cast<std::size_t>(pose_index(k))].translation(); });
    return;
  }
  const auto first = std::lower_bound(record_pose_index_.begin(), record_pose_index_.end(), moved_from) - record_pose_index_.begin();
  gate_.update_positions_from(static_cast<std::size_t>(first),
                              [this, &poses](std::size_t i) { return poses[static_cast<std::size_t>(record_pose_index_[i])].translation(); });
}

void LoopDetector::add_to_gate(const KeyframeRecord& keyframe, const Eigen::Vector3d& position) {
  gate_.add({keyframe.key, position, travelled_});
  if (!keyframe.features) gate_.retire(gate_.size() - 1);  // never a candidate, so in no cell of the gate
}

std::shared_ptr<const KeyframeFeatures> LoopDetector::thinned(const KeyframeFeatures& features) {
  auto thin = std::make_shared<KeyframeFeatures>();
  thin->ok = features.ok;
  thin->error = features.error;
  thin->descriptor = features.descriptor;
  thin->ms_descriptor = features.ms_descriptor;
  thin->ms_prepare = features.ms_prepare;
  thin->input_points = features.input_points;
  thin->invalid_points = features.invalid_points;
  thin->scene_scale = features.scene_scale;  // the query's travel gap and verification settings (a handheld revisit)
  thin->prepared_in_store = true;
  return thin;
}

void LoopDetector::add_ground_plane(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_query) {
  // Ren 2019, Sec. 3.4.2: the roadway plane as a landmark. The ground is the largest near-horizontal planar segment
  // below the sensor; keyframes in the same ground cell (plane_cell_size) observe the same plane node.
  const Cluster* ground = nullptr;
  for (const Cluster& c : keyframe.features->prepared.segmentation.clusters) {
    if (!c.planar || std::abs(c.plane.z()) < 0.97f || c.centroid.z() > -0.5f) continue;
    if (!ground || c.num_points > ground->num_points) ground = &c;
  }
  if (!ground) return;
  PlaneObservation obs;
  obs.index = pose_index(keyframe.key);
  const auto cx = static_cast<std::int64_t>(std::floor(T_map_query.translation().x() / config_.plane_cell_size));
  const auto cy = static_cast<std::int64_t>(std::floor(T_map_query.translation().y() / config_.plane_cell_size));
  obs.plane_id = static_cast<int>(((cx * 73856093) ^ (cy * 19349663)) & 0x7fffffff);
  obs.plane_sensor = ground->plane.cast<double>();
  corrector_.add_plane_observation(obs);
}

LoopDecision LoopDetector::make_decision(const KeyframeRecord& query, const RankedCandidate& candidate, double radius) {
  LoopDecision d;
  const auto expected = expected_event_ids_.find({query.utime, candidate.match->key});
  if (expected != expected_event_ids_.end()) {
    d.event_id = expected->second;  // decided before a stop cut its keyframe off: the same candidate, the same id
    expected_event_ids_.erase(expected);
  } else {
    d.event_id = next_event_id_++;
  }
  d.query = query.key;
  d.query_utime = query.utime;
  d.match = candidate.match->key;
  d.match_utime = candidate.match->utime;
  d.gate_distance = candidate.gate_distance;
  d.gate_radius = radius;
  d.descriptor_distance = candidate.descriptor_distance;
  return d;
}

void LoopDetector::report(LoopDecision decision, DetectorOutput& out, const DecisionCallback& on_decided) {
  if (decision.status == LoopStatus::kAccepted) {
    ++loop_ends_[decision.query];
    ++loop_ends_[decision.match];
  }
  out.decisions.push_back(std::move(decision));
  if (on_decided) on_decided(out.decisions.back());
}

void LoopDetector::report_descriptor_rejection(const KeyframeRecord& query, const RankedCandidate& best, double radius, DetectorOutput& out,
                                               const DecisionCallback& on_decided) {
  // The best gated candidate's descriptor score is reported even when it is not verified (PR curves need it).
  LoopDecision d = make_decision(query, best, radius);
  d.status = LoopStatus::kRejected;
  d.stage = "descriptor";
  d.ms_descriptor = query.features->ms_descriptor;
  d.reason = "descriptor distance above threshold";
  ++loops_rejected_;
  report(std::move(d), out, on_decided);
}

bool LoopDetector::guided(const KeyframeKey& query) const {
  return last_accepted_ && keyframes_between(*last_accepted_, query) <= config_.guided_window;
}

std::optional<CorrectionOutput> LoopDetector::close_loop(const KeyframeRecord& query, const RankedCandidate& match, const VerifyResult& verification,
                                                         LoopDecision decision, DetectorOutput& out, const DecisionCallback& on_decided) {
  LoopConstraint loop = to_loop_constraint(verification, pose_index(query.key), pose_index(match.match->key));
  loop.robust = !decision.confirmed;
  const std::optional<std::string> refused = corrector_.check_loop(loop);
  if (refused) decision.reason = "accepted, but the correction refused the loop: " + *refused;
  const std::int64_t event_id = decision.event_id;
  if (!refused) sessions_.tie(query.key.session, match.match->key.session);
  report(std::move(decision), out, on_decided);  // before the correction: the event need not wait for the pose graph
  ++loops_accepted_;
  last_accepted_ = query.key;
  travelled_at_last_loop_ = travelled_;
  if (refused) return std::nullopt;
  // Vlaminck 2019 Sec. 4.4 / Ren 2019 Sec. 3.4.3: the heuristic, then the pose graph.
  Stopwatch sw;
  const CorrectionResult result = corrector_.add_loop(loop);
  if (corrector_.loops().size() > loop_events_.size()) loop_events_.push_back(event_id);
  if (!result.ok) return std::nullopt;  // check_loop() said it would take it; nothing else refuses
  return correction_output(result, event_id, sw);
}

CorrectionOutput LoopDetector::correction_output(const CorrectionResult& result, std::int64_t loop_event_id, const Stopwatch& sw) {
  CorrectionOutput c;
  c.revision = ++revision_;
  c.loop_event_id = loop_event_id;
  c.method = to_string(result.method);
  c.graph_solved = result.graph_solved;
  c.T_map_odom = T_map_odom();
  c.sessions = session_alignments();
  c.resume_state = corrector_.resume_state();
  c.ledger_seq = ledger_seq_;
  const std::vector<Eigen::Isometry3d>& corrected = corrector_.corrected_poses();
  const std::vector<KeyframeRecord>& records = keyframes_.records();
  c.keys.resize(records.size());
  c.utimes.resize(records.size());
  c.T_map_sensor.resize(records.size());
  for (std::size_t i = 0; i < records.size(); ++i) {
    c.keys[i] = records[i].key;
    c.utimes[i] = records[i].utime;
    c.T_map_sensor[i] = corrected[static_cast<std::size_t>(record_pose_index_[i])];
  }
  correction_moved_from_ = result.moved_from;
  c.ms = sw.ms();
  last_correction_event_id_ = loop_event_id;
  keyframes_at_correction_ = keyframes_.size();
  correction_was_graph_ = result.graph_solved && !result.graph_deferred;
  return c;
}

std::optional<CorrectionOutput> LoopDetector::final_correction() {
  if (revision_ == 0 || (correction_was_graph_ && keyframes_at_correction_ == keyframes_.size() && !corrector_.graph_pending())) return std::nullopt;
  Stopwatch sw;
  const CorrectionResult result = corrector_.solve_all();
  if (!result.ok) return std::nullopt;
  CorrectionOutput c = correction_output(result, last_correction_event_id_, sw);
  c.method = "final";  // one pose-graph solve of everything, at the end of a run
  update_gate(result.moved_from);
  return c;
}

std::optional<MeasuredStep> LoopDetector::measure_step(const KeyframeFeatures* features, const Eigen::Isometry3d& T_continuous_sensor) {
  if (!config_.steps.enabled || !features || keyframes_.empty() || !keyframes_.newest().features) return std::nullopt;
  const std::shared_ptr<const KeyframeFeatures> previous = full_features(keyframes_.newest());
  if (!previous || previous->prepared.points.empty() || features->prepared.points.empty()) return std::nullopt;
  const Eigen::Isometry3d odometry_step = corrector_.odometry_poses().back().inverse() * T_continuous_sensor;
  const Eigen::Matrix3d R_odom_previous = corrector_.odometry_poses().back().linear();
  KeyframeStep step = measure_keyframe_step(previous->prepared.points, previous->prepared.unpacked_normals(), features->prepared.points,
                                            features->prepared.unpacked_normals(), odometry_step, config_.steps, &R_odom_previous);
  if (!step.measured) {
    ++steps_refused_;
    return std::nullopt;
  }
  return MeasuredStep{step.T_previous_current, step.information};
}

Eigen::Isometry3d LoopDetector::enter_pose_sequence(const KeyframeInput& input, const KeyframeFeatures* features,
                                                    const std::optional<MeasuredStep>* stored, std::optional<MeasuredStep>* step_used) {
  // One pose sequence for every session: a new session is stitched on where the last keyframe lay (SessionFrames) and
  // its join carries no odometry, so only loops place it.
  const bool first = corrector_.size() == 0;
  const Eigen::Isometry3d T_previous = first ? Eigen::Isometry3d::Identity() : corrector_.odometry_poses().back();
  const SessionFrames::Placed placed = sessions_.place(input.key, input.T_odom_sensor);
  if (placed.starts_segment) {
    travelled_at_last_loop_ = travelled_;  // the new session's drift starts with it
    pose_index_[input.key] = corrector_.add_segment_start(placed.T_continuous_sensor);
  } else {
    if (!first) travelled_ += (T_previous.inverse() * placed.T_continuous_sensor).translation().norm();
    std::optional<MeasuredStep> step;
    if (!first && stored) {
      step = *stored;
    } else if (!first && config_.steps.enabled) {
      step = input.motion_compensated ? measure_step(features, placed.T_continuous_sensor) : std::nullopt;
      if (!input.motion_compensated) ++steps_skewed_;
    }
    pose_index_[input.key] = step ? corrector_.add_keyframe(placed.T_continuous_sensor, input.residual, step->information, step->T_previous_this)
                                  : corrector_.add_keyframe(placed.T_continuous_sensor, input.residual);
    if (step_used) *step_used = step;
  }
  return corrector_.corrected_poses().back();
}

LoopDetector::GatedOutcome LoopDetector::close_gated(const KeyframeRecord& query, const Eigen::Isometry3d& T_map_query, DetectorOutput& out,
                                                     const DecisionCallback& on_decided) {
  // Sec. 4 and 4.1: keyframes within the gate radius (10 % of the travel since the last loop), by M2DP distance; only
  // sessions tied to the query's share its frame.
  GatedOutcome g;
  g.radius = gate_.radius(travelled_ - travelled_at_last_loop_);
  const GateEntry here{query.key, T_map_query.translation(), travelled_};
  g.gated = gate_.candidates(
      here, g.radius, [&](const KeyframeKey& k) { return sessions_.tied(k.session, query.key.session); },
      gate_.travel_gap(query.features->scene_scale, g.radius));
  const std::vector<RankedCandidate> ranked = rank_by_descriptor(g.gated, query.features->descriptor, keyframes_);
  const std::size_t count = count_to_verify(ranked, config_.max_descriptor_distance, config_.max_candidates_per_keyframe);
  if (count == 0 && !ranked.empty()) report_descriptor_rejection(query, ranked.front(), g.radius, out, on_decided);
  // Sec. 4.2-4.3: verify best first; the first accepted candidate closes the loop and (Sec. 4.4) corrects the map.
  CandidateVerifications verifications = start_verifications(query, ranked, count, T_map_query);
  for (std::size_t i = 0; i < count; ++i) {
    LoopDecision d = make_decision(query, ranked[i], g.radius);
    g.verified.push_back(ranked[i].match->key);
    VerifyResult v = verifications.get(i);
    if (v.accepted) check_prior_rotation(*ranked[i].match, T_map_query, &v);
    apply_verification(v, query.features->ms_descriptor, d);
    if (!v.accepted && v.reason.rfind("prior:", 0) == 0) d.stage = "prior";
    if (v.accepted) {
      out.correction = close_loop(query, ranked[i], v, std::move(d), out, on_decided);
      g.accepted = true;
      confirmation_.clear();
      break;
    }
    report(std::move(d), out, on_decided);
    ++loops_rejected_;
  }
  return g;
}

void LoopDetector::check_prior_rotation(const KeyframeRecord& match, const Eigen::Isometry3d& T_map_query, VerifyResult* v) const {
  const Eigen::Isometry3d T_match_query_prior = corrector_.corrected_poses()[static_cast<std::size_t>(pose_index(match.key))].inverse() * T_map_query;
  const double deg = Eigen::AngleAxisd(T_match_query_prior.linear().transpose() * v->T_match_query.linear()).angle() * 180.0 / M_PI;
  if (deg <= config_.max_prior_rotation_deg) return;
  char why[200];
  std::snprintf(
      why, sizeof why,
      "prior: the alignment turns %.1f deg away from the corrected map's relative pose (max %.1f): a self-similar place aligned turned round", deg,
      config_.max_prior_rotation_deg);
  v->accepted = false;
  v->reason = why;
}

std::function<bool(const KeyframeKey&)> LoopDetector::prior_free_filter(const KeyframeRecord& query, const GatedOutcome& gated) const {
  // Not the candidates the gate's path verified. Of sessions in the query's frame (its own and those tied to it) only
  // once the gate's radius is at its clamp, where drift may outgrow the gate (before that the gate's own candidates
  // are compared, retrieve_places()), and of the query's session only keyframes far back along the drive (the newest
  // such index, found once); of another session any keyframe the query's session may be tied to (decided once per
  // session). The index calls this for every stored keyframe: it must stay a few comparisons.
  const bool beyond_gate = gated.radius >= config_.gate.max_radius;
  std::int64_t newest_allowed = query.key.index - config_.gate.min_index_gap;
  // Scale from the scene, as the gate's own travel gap (the same share of the configured gap).
  const double gap_share =
      config_.gate.min_travel_gap > 0.0 ? gate_.travel_gap(query.features->scene_scale, gated.radius) / config_.gate.min_travel_gap : 1.0;
  const double retrieval_travel_gap = config_.retrieval.min_travel_gap * gap_share;
  const std::vector<KeyframeRecord>& records = keyframes_.records();
  for (auto it = records.rbegin(); it != records.rend() && it->key.session == query.key.session; ++it) {
    if (query.travelled - it->travelled >= retrieval_travel_gap) {  // travel grows along a session
      newest_allowed = std::min(newest_allowed, it->key.index);
      break;
    }
    newest_allowed = std::min(newest_allowed, it->key.index - 1);
  }
  std::map<SessionId, bool> other_sessions;
  for (const SessionId session : sessions_.sessions())
    if (session != query.key.session)
      other_sessions[session] = sessions_.tied(query.key.session, session) ? beyond_gate : !sessions_.cannot_tie(query.key.session, session);
  // Other vehicles' sessions (remote_): any keyframe.
  return [query_session = query.key.session, newest_allowed, beyond_gate, other_sessions = std::move(other_sessions), verified = gated.verified,
          remote = &remote_](const KeyframeKey& k) {
    if (k.session == query_session) {
      if (!beyond_gate || k.index > newest_allowed) return false;
    } else if (!remote->holds_session(k.session)) {
      const auto it = other_sessions.find(k.session);
      if (it == other_sessions.end() || !it->second) return false;
    }
    return std::find(verified.begin(), verified.end(), k) == verified.end();
  };
}

void LoopDetector::close_prior_free(const KeyframeRecord& query, const Eigen::Isometry3d& T_map_query, const GatedOutcome& gated, DetectorOutput& out,
                                    const DecisionCallback& on_decided) {
  const std::shared_ptr<const KeyframeFeatures> query_features = full_features(query);
  if (!query_features || !query_features->place.ok) return;
  const std::vector<PlaceCandidate> places = retrieve_places(*query_features, gated, prior_free_filter(query, gated));
  // In the query's own frame the odometry still bounds the drift since the last loop: a place farther off is another.
  const double max_correction = std::max(gated.radius, config_.retrieval.max_drift_fraction * (travelled_ - travelled_at_last_loop_));
  std::size_t verified = 0;
  for (std::size_t i = 0; i < places.size() && verified < static_cast<std::size_t>(config_.retrieval.max_verified); ++i) {
    if (remote_.holds_session(places[i].key.session)) {
      if (!remote_.find(places[i].key)) continue;
      ++verified;
      const RemoteOutcome remote = close_remote(query, *query_features, T_map_query, places[i], gated.radius, out, on_decided);
      if (remote != RemoteOutcome::kRejected) return;
      continue;
    }
    const KeyframeRecord* match = keyframes_.find(places[i].key);
    if (!match || !match->features) continue;
    RankedCandidate candidate{match, (corrected(match->key).translation() - T_map_query.translation()).norm(),
                              (match->features->descriptor - query.features->descriptor).norm()};
    if (sessions_.tied(match->key.session, query.key.session) && candidate.gate_distance > max_correction) continue;
    ++verified;
    LoopDecision d = make_decision(query, candidate, gated.radius);
    d.retrieval = "global";
    d.place_distance = places[i].place_distance;
    // The full verification, no guess from the map: nothing is known about where the query lies.
    const std::shared_ptr<const KeyframeFeatures> match_features = full_features(*match);
    VerifyResult v;
    if (match_features)
      v = verify_candidate(query_features->prepared, match_features->prepared, std::nullopt, verify_config_for(query));
    else
      v.reason = "the keyframe's features could not be read back from the map store";
    // A place within the gate of a session tied to the query's has the map's prior: no confirmation (as the gate's own),
    // and its rotation must agree with the prior's (as the gate's own).
    const bool within_gate = sessions_.tied(match->key.session, query.key.session) && candidate.gate_distance <= gated.radius;
    if (v.accepted && within_gate) check_prior_rotation(*match, T_map_query, &v);
    apply_verification(v, query.features->ms_descriptor, d);
    if (!v.accepted && v.reason.rfind("prior:", 0) == 0) d.stage = "prior";
    if (v.accepted && within_gate) d.reason = "place retrieval within the gate: " + d.reason;
    if (v.accepted && (within_gate || confirm_prior_free(query, *match, v, T_map_query, d))) {
      out.correction = close_loop(query, candidate, v, std::move(d), out, on_decided);
      return;
    }
    report(std::move(d), out, on_decided);
    ++loops_rejected_;
    if (v.accepted) return;  // held for confirmation: the next keyframes decide
  }
}

std::vector<PlaceCandidate> LoopDetector::retrieve_places(const KeyframeFeatures& query, const GatedOutcome& gated,
                                                          const std::function<bool(const KeyframeKey&)>& accept) const {
  // The nearest places among the keyframes `accept` lets through, and among the gate's candidates its path did not
  // verify (M2DP ranked them out), to the scan and to its laterally shifted views; each keyframe once, nearest first.
  std::vector<const PlaceDescriptor*> views{&query.place};
  for (const PlaceDescriptor& shifted : query.place_shifted) views.push_back(&shifted);
  std::vector<PlaceCandidate> all = places_.query_views(views, config_.retrieval.retrieval, accept);
  std::vector<KeyframeKey> unverified;
  for (const GateCandidate& c : gated.gated)
    if (std::find(gated.verified.begin(), gated.verified.end(), c.key) == gated.verified.end()) unverified.push_back(c.key);
  for (const PlaceCandidate& c : places_.compare(views, unverified, config_.retrieval.retrieval.max_place_distance))
    if (std::none_of(all.begin(), all.end(), [&](const PlaceCandidate& a) { return a.key == c.key; })) all.push_back(c);
  std::sort(all.begin(), all.end(), [](const PlaceCandidate& a, const PlaceCandidate& b) {
    return a.place_distance < b.place_distance || (a.place_distance == b.place_distance && a.key < b.key);
  });
  return all;
}

bool LoopDetector::confirm_prior_free(const KeyframeRecord& query, const KeyframeRecord& match, const VerifyResult& verification,
                                      const Eigen::Isometry3d& T_map_query, LoopDecision& decision) {
  // The stricter test: a loop of one of the next keyframes must imply the same placement of the query's session.
  PriorFreeLoop loop;
  loop.query = query.key;
  loop.match_group = sessions_.group(match.key.session);
  loop.correction = corrected(match.key) * verification.T_match_query * T_map_query.inverse();
  loop.p_map_query = T_map_query.translation();
  loop.event_id = decision.event_id;
  return confirm_prior_free_loop(loop, decision);
}

bool LoopDetector::confirm_prior_free_loop(const PriorFreeLoop& loop, LoopDecision& decision) {
  const std::optional<PriorFreeLoop> agreed = confirmation_.confirm(loop);
  if (agreed) {
    const auto [translation, rotation] = PriorFreeConfirmation::disagreement(*agreed, loop);
    char why[160];
    std::snprintf(why, sizeof why, "prior-free loop confirmed by event %lld (keyframe %s): the placements agree within %.3f m / %.2f deg",
                  static_cast<long long>(agreed->event_id), to_string(agreed->query).c_str(), translation, rotation);
    decision.reason = why;
    decision.confirmed = true;
    return true;
  }
  decision.status = LoopStatus::kRejected;
  decision.stage = "confirmation";
  decision.reason = "verified without a pose prior; links nothing until a loop of one of the next " +
                    std::to_string(config_.retrieval.confirm_window) + " keyframes agrees";
  return false;
}

DetectorOutput LoopDetector::add_keyframe(const KeyframeInput& input, std::shared_ptr<const KeyframeFeatures> features,
                                          const DecisionCallback& on_decided,
                                          const std::function<void(const KeyframeRecord&, const Eigen::Isometry3d&)>& on_placed) {
  // A pose-graph solve that ran beside the last keyframes is applied first, at a fixed keyframe (replay = live).
  Stopwatch apply_watch;
  const std::optional<CorrectionResult> applied = corrector_.apply_graph();
  if (applied) update_gate(applied->moved_from);
  const double apply_ms = apply_watch.ms();
  // Vlaminck 2019 Sec. 4: the keyframe enters the map where the corrected odometry puts it.
  if (features && !features->ok) features.reset();
  std::optional<MeasuredStep> step;
  const Eigen::Isometry3d T_map_query = enter_pose_sequence(input, features.get(), nullptr, &step);
  const KeyframeRecord& query = place_keyframe(input, std::move(features), T_map_query, step);
  if (on_placed) {
    KeyframeRecord placed = query;  // with its full features: what a store must keep even when memory keeps less
    placed.features = full_features(query);
    on_placed(placed, T_map_query);
  }

  DetectorOutput out;
  if (query.features) {
    // Sec. 4-4.4: the gate's candidates, verified best first; the first accepted one corrects the map.
    const GatedOutcome gated = close_gated(query, T_map_query, out, on_decided);
    // Without a pose prior: every stored keyframe by its place descriptor, fully verified, and confirmed by the next keyframes.
    if (!gated.accepted && config_.retrieval.enabled) close_prior_free(query, T_map_query, gated, out, on_decided);
  }
  add_to_gate(query, T_map_query.translation());
  if (out.correction) update_gate(correction_moved_from_);
  if (applied) {
    if (!out.correction) {  // a revision of its own (its loop event: the newest correction's)
      Stopwatch sw;
      out.correction = correction_output(*applied, last_correction_event_id_, sw);
    } else {
      out.correction->graph_solved = true;  // this revision includes it (the engine frees memory after a solve)
    }
    out.correction->ms += apply_ms;
  }
  return out;
}

Eigen::Isometry3d LoopDetector::T_map_odom() const {
  const std::optional<SessionId> session = sessions_.current();
  return corrector_.T_map_odom() * (session ? sessions_.T_continuous_odom(*session) : Eigen::Isometry3d::Identity());
}

std::vector<SessionAlignment> LoopDetector::session_alignments() const {
  std::map<SessionId, Eigen::Isometry3d> T_map_newest;
  for (const auto& [session, newest] : sessions_.newest()) T_map_newest[session] = corrected(newest.first);
  return sessions_.alignments(T_map_newest);
}
std::size_t LoopDetector::num_keyframes() const { return keyframes_.size(); }
std::size_t LoopDetector::bytes_per_keyframe() const { return keyframes_.bytes_per_keyframe(); }
std::string LoopDetector::descriptor_device() const { return m2dp_->device_name(); }

}  // namespace loopd
