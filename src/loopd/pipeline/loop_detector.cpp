#include "loopd/pipeline/loop_detector.hpp"

#include <algorithm>
#include <cmath>
#include <future>

#include "loopd/core/cloud_ops.hpp"
#include "loopd/core/stopwatch.hpp"

namespace loopd {

struct LoopDetector::StoredKeyframe {
  KeyframeInput input;
  std::shared_ptr<const KeyframeFeatures> features;  ///< null when shed
  double travelled = 0.0;
};

std::optional<std::string> LoopDetectorConfig::validate() const {
  if (!lidar_model_from_name(sensor)) return "sensor: unknown lidar model '" + sensor + "' (vlp16, hdl32, hdl64, os1-64)";
  if (auto e = keyframe.validate()) return e;
  if (auto e = gate.validate()) return e;
  if (auto e = m2dp.validate()) return "m2dp: " + *e;
  if (auto e = verify.validate()) return "verify: " + *e;
  if (auto e = correction.validate()) return "correction: " + *e;
  if (!(max_descriptor_distance > 0.0)) return "max_descriptor_distance must be > 0";
  if (max_candidates_per_keyframe < 1) return "max_candidates_per_keyframe must be >= 1";
  if (guided_window < 0) return "guided_window must be >= 0";
  return std::nullopt;
}

LoopDetector::LoopDetector(const LoopDetectorConfig& config)
    : config_(config),
      model_(lidar_model_from_name(config.sensor)),
      m2dp_(std::make_unique<M2dp>(config.m2dp)),
      gate_(config.gate),
      corrector_(config.correction) {}

LoopDetector::~LoopDetector() = default;

KeyframeFeatures LoopDetector::compute_features(const PointCloud& scan) const {
  KeyframeFeatures f;
  f.input_points = scan.size();
  std::size_t removed = 0;
  for (const Eigen::Vector3f& p : scan.points) removed += p.allFinite() ? 0 : 1;
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
  sw.reset();
  f.prepared = prepare_scan(clean, model_ ? &*model_ : nullptr, config_.prepare);
  f.ms_prepare = sw.ms();
  f.ok = true;
  return f;
}

void LoopDetector::add_ground_plane(std::int64_t id, const KeyframeFeatures& features, const Eigen::Isometry3d& T_map_query) {
  // Ren 2019, Sec. 3.4.2: the roadway plane as a landmark. The ground is the largest near-horizontal planar segment
  // below the sensor; keyframes in the same ground cell (plane_cell_size) observe the same plane node.
  const Cluster* ground = nullptr;
  for (const Cluster& c : features.prepared.segmentation.clusters) {
    if (!c.planar || std::abs(c.plane.z()) < 0.97f || c.centroid.z() > -0.5f) continue;
    if (!ground || c.num_points > ground->num_points) ground = &c;
  }
  if (!ground) return;
  PlaneObservation obs;
  obs.index = static_cast<int>(id);
  const auto cx = static_cast<std::int64_t>(std::floor(T_map_query.translation().x() / config_.plane_cell_size));
  const auto cy = static_cast<std::int64_t>(std::floor(T_map_query.translation().y() / config_.plane_cell_size));
  obs.plane_id = static_cast<int>(((cx * 73856093) ^ (cy * 19349663)) & 0x7fffffff);
  obs.plane_sensor = ground->plane.cast<double>();
  corrector_.add_plane_observation(obs);
}

LoopDecision LoopDetector::make_decision(const KeyframeInput& q, const StoredKeyframe& m, double gate_distance, double radius) {
  LoopDecision d;
  d.event_id = next_event_id_++;
  d.query_id = q.id;
  d.query_utime = q.utime;
  d.match_id = m.input.id;
  d.match_utime = m.input.utime;
  d.gate_distance = gate_distance;
  d.gate_radius = radius;
  return d;
}

DetectorOutput LoopDetector::add_keyframe(const KeyframeInput& input, std::shared_ptr<const KeyframeFeatures> features,
                                          const std::function<void(const LoopDecision&)>& on_decided) {
  DetectorOutput out;
  if (!keyframes_.empty()) travelled_ += (keyframes_.back().input.T_odom_sensor.inverse() * input.T_odom_sensor).translation().norm();
  if (features && !features->ok) features.reset();

  // Current best estimate of where this keyframe is: the odometry pose in the corrected map frame.
  corrector_.add_keyframe(input.T_odom_sensor, input.residual);
  const Eigen::Isometry3d T_map_query = corrector_.T_map_odom() * input.T_odom_sensor;

  if (features && config_.correction.graph.use_plane_constraints) add_ground_plane(input.id, *features, T_map_query);
  StoredKeyframe stored{input, features, travelled_};
  if (features) {
    stored_bytes_ += features->prepared.bytes() + static_cast<std::size_t>(features->descriptor.size()) * sizeof(float);
  }
  stored_bytes_ += sizeof(StoredKeyframe);
  keyframes_.push_back(stored);
  const GateEntry query{input.id, T_map_query.translation(), travelled_};

  if (features) {
    // Vlaminck 2019 Sec. 4: candidates within 10% of the distance travelled since the last loop.
    const double radius = gate_.radius(travelled_ - travelled_at_last_loop_);
    struct Ranked {
      const StoredKeyframe* kf;
      double gate_distance;
      double descriptor_distance;
    };
    std::vector<Ranked> ranked;
    for (const GateCandidate& c : gate_.candidates(query, radius)) {
      const StoredKeyframe& m = keyframes_[static_cast<std::size_t>(c.id)];
      if (!m.features) continue;
      ranked.push_back({&m, c.distance, descriptor_distance(features->descriptor, m.features->descriptor)});
    }
    std::sort(ranked.begin(), ranked.end(), [](const Ranked& a, const Ranked& b) {
      return a.descriptor_distance < b.descriptor_distance || (a.descriptor_distance == b.descriptor_distance && a.kf->input.id < b.kf->input.id);
    });

    // Candidates to verify: under the descriptor threshold, best first, at most max_candidates_per_keyframe.
    std::size_t num_verify = 0;
    while (num_verify < ranked.size() && static_cast<int>(num_verify) < config_.max_candidates_per_keyframe &&
           ranked[num_verify].descriptor_distance <= config_.max_descriptor_distance)
      ++num_verify;
    if (num_verify == 0 && !ranked.empty()) {
      // Report the best gated candidate's descriptor score even when it is not verified (PR curves need it).
      const Ranked& r = ranked.front();
      LoopDecision d = make_decision(input, *r.kf, r.gate_distance, radius);
      d.status = LoopStatus::kRejected;
      d.stage = "descriptor";
      d.descriptor_distance = r.descriptor_distance;
      d.ms_descriptor = features->ms_descriptor;
      d.reason = "descriptor distance above threshold";
      ++loops_rejected_;
      out.decisions.push_back(d);
      if (on_decided) on_decided(d);
    }
    const bool guided = input.id - last_accepted_id_ <= config_.guided_window;
    // One candidate's verification; reads nothing that changes while it runs (the guess is computed up front).
    auto verify_candidate = [this, guided, &features](const PreparedScan* match, Eigen::Isometry3d guess) {
      VerifyResult v;
      if (guided) {
        // The corrected map is locally consistent right after a loop: its relative pose seeds GICP.
        v = verify_from_guess(features->prepared, *match, guess, config_.verify);
      }
      if (!guided || !v.accepted) {
        const double guided_ms = guided ? v.ms_total : 0.0;
        v = verify(features->prepared, *match, config_.verify);
        v.ms_total += guided_ms;
      } else {
        v.reason = "guided: GICP from the corrected map's relative pose (4PCS skipped)" + (v.reason.empty() ? std::string() : "; " + v.reason);
      }
      return v;
    };
    std::vector<Eigen::Isometry3d> guesses(num_verify, Eigen::Isometry3d::Identity());
    for (std::size_t i = 0; i < num_verify; ++i)
      if (guided) guesses[i] = corrector_.corrected_poses()[static_cast<std::size_t>(ranked[i].kf->input.id)].inverse() * T_map_query;
    // Live mode verifies the other candidates concurrently (spare cores cut the latency tail); the decision is the
    // same either way: the first accepted candidate in rank order wins and later ones are not reported.
    std::vector<std::future<VerifyResult>> pending(num_verify);
    if (config_.parallel_candidates && !guided)
      for (std::size_t i = 1; i < num_verify; ++i)
        pending[i] = std::async(std::launch::async, verify_candidate, &ranked[i].kf->features->prepared, guesses[i]);

    for (std::size_t i = 0; i < num_verify; ++i) {
      const Ranked& r = ranked[i];
      LoopDecision d = make_decision(input, *r.kf, r.gate_distance, radius);
      d.descriptor_distance = r.descriptor_distance;
      d.ms_descriptor = features->ms_descriptor;
      const VerifyResult v = pending[i].valid() ? pending[i].get() : verify_candidate(&r.kf->features->prepared, guesses[i]);
      d.stage = v.accepted ? "accepted" : to_string(v.stage);
      d.reason = v.reason;
      d.lcp_fraction = v.lcp_fraction;
      d.icp_residual = v.icp_residual;
      d.icp_fitness = v.icp_fitness;
      d.hungarian_consistency = v.hungarian_consistency;
      d.degeneracy = v.degeneracy;
      d.T_match_query = v.T_match_query;
      d.ms_fourpcs = v.ms_fourpcs;
      d.ms_gicp = v.ms_gicp;
      d.ms_hungarian = v.ms_hungarian;
      d.ms_total = v.ms_total + features->ms_descriptor;
      d.status = v.accepted ? LoopStatus::kAccepted : LoopStatus::kRejected;
      LoopConstraint loop;
      loop.query_index = static_cast<int>(input.id);
      loop.match_index = static_cast<int>(r.kf->input.id);
      loop.T_match_query = v.T_match_query;
      // verify() gives the GICP information in (rx, ry, rz, tx, ty, tz) order; the corrector takes (t, r).
      loop.information.topLeftCorner<3, 3>() = v.information.bottomRightCorner<3, 3>();
      loop.information.bottomRightCorner<3, 3>() = v.information.topLeftCorner<3, 3>();
      loop.information.topRightCorner<3, 3>() = v.information.bottomLeftCorner<3, 3>();
      loop.information.bottomLeftCorner<3, 3>() = v.information.topRightCorner<3, 3>();
      const std::optional<std::string> refused = v.accepted ? corrector_.check_loop(loop) : std::nullopt;
      if (refused) d.reason = "accepted, but the correction refused the loop: " + *refused;
      out.decisions.push_back(d);
      if (on_decided) on_decided(d);  // before the correction: the event need not wait for the pose graph
      if (!v.accepted) {
        ++loops_rejected_;
        continue;
      }
      ++loops_accepted_;
      last_accepted_id_ = input.id;
      travelled_at_last_loop_ = travelled_;
      if (refused) break;
      Stopwatch sw;
      const CorrectionResult cr = corrector_.add_loop(loop);
      if (!cr.ok) break;  // check_loop() said it would take it; nothing else refuses
      CorrectionOutput c;
      c.revision = ++revision_;
      c.loop_event_id = d.event_id;
      c.method = to_string(cr.method);
      c.T_map_sensor = corrector_.corrected_poses();
      c.T_map_odom = corrector_.T_map_odom();
      c.ids.reserve(keyframes_.size());
      c.utimes.reserve(keyframes_.size());
      for (const auto& k : keyframes_) {
        c.ids.push_back(k.input.id);
        c.utimes.push_back(k.input.utime);
      }
      c.ms = sw.ms();
      out.correction = std::move(c);
      break;
    }
  }
  gate_.add({input.id, T_map_query.translation(), travelled_});
  if (out.correction) {
    std::vector<Eigen::Vector3d> positions;
    for (const auto& T : out.correction->T_map_sensor) positions.push_back(T.translation());
    gate_.update_positions(positions);
  }
  return out;
}

Eigen::Isometry3d LoopDetector::T_map_odom() const { return corrector_.T_map_odom(); }
std::size_t LoopDetector::num_keyframes() const { return keyframes_.size(); }
std::size_t LoopDetector::bytes_per_keyframe() const { return keyframes_.empty() ? 0 : stored_bytes_ / keyframes_.size(); }
std::string LoopDetector::descriptor_device() const { return m2dp_->device_name(); }

}  // namespace loopd
