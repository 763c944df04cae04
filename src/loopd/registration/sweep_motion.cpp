#include "loopd/registration/sweep_motion.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <vector>

#include "loopd/base/pose.hpp"
#include "loopd/base/stopwatch.hpp"
#include "loopd/base/voxel_grid.hpp"
#include "loopd/base/angles.hpp"

namespace loopd {
namespace {

/// Voxel centroids of a sweep's finite, timed points within [min_range, max_range], each with its points' mean time
/// and the normal of their scatter (zero where they form no plane: too few, or an edge, a corner, foliage).
struct TimedVoxels {
  std::vector<Eigen::Vector3f> points, normals;
  std::vector<float> time;
};

struct VoxelMoments {
  double time = 0.0;
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();  ///< sum of p p^T
};

/// Every stride-th point keeps at most max_input_points (1 below it, and for an already reduced cloud).
std::size_t input_stride(std::size_t n, int max_input_points) {
  if (max_input_points <= 0) return 1;
  const auto max = static_cast<std::size_t>(max_input_points);
  return std::max<std::size_t>(1, (n + max - 1) / max);
}

TimedVoxels timed_voxels(const PointCloud& cloud, const SweepMotionConfig& config) {
  const std::size_t stride = input_stride(cloud.size(), config.max_input_points);
  VoxelGrid<VoxelMoments> grid(config.voxel_size, cloud.size() / (8 * stride) + 16);
  const double min2 = config.min_range * config.min_range, max2 = config.max_range * config.max_range;
  for (std::size_t i = 0; i < cloud.size(); i += stride) {
    const Eigen::Vector3f& p = cloud.points[i];
    const float t = cloud.time[i];
    if (!p.allFinite() || !std::isfinite(t)) continue;
    const double r2 = p.squaredNorm();
    if (r2 < min2 || r2 > max2) continue;
    if (auto* v = grid.add(p)) {
      const Eigen::Vector3d q = p.cast<double>();
      v->payload.time += t;
      v->payload.outer += q * q.transpose();
    }
  }
  TimedVoxels out;
  const auto voxels = std::move(grid).sorted_voxels();
  out.points.reserve(voxels.size());
  out.normals.reserve(voxels.size());
  out.time.reserve(voxels.size());
  constexpr std::uint32_t kMinPlanePoints = 5;
  for (const auto& v : voxels) {
    const double n = static_cast<double>(v.count);
    const Eigen::Vector3d mean = v.sum / n;
    out.points.push_back(mean.cast<float>());
    out.time.push_back(static_cast<float>(v.payload.time / n));
    Eigen::Vector3f normal = Eigen::Vector3f::Zero();
    if (v.count >= kMinPlanePoints) {
      const Eigen::Matrix3d C = v.payload.outer / n - mean * mean.transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
      es.computeDirect(C);
      const Eigen::Vector3d l = es.eigenvalues();  // ascending
      if (l(0) < config.max_plane_thickness * l(1)) normal = es.eigenvectors().col(0).normalized().cast<float>();
    }
    out.normals.push_back(normal);
  }
  return out;
}

/// The centroids (and their normals) moved into their stamp's frame. The sensor's path through both sweeps is the one
/// deskew() interpolates between two poses: P(tau) = interpolate(I, T_previous_current, tau / dt) in the previous
/// stamp's frame (translation on a line, rotation at a constant rate), tau [s] after the previous stamp. A point of the
/// previous sweep at time t was seen from P(t); one of the current sweep from T_previous_current^-1 P(dt + t).
/// The previous sweep's own motion, when it differed, is `velocity` (its increment over velocity_dt) instead.
/// A sweep with a bend (a gyro's turn through it) is moved along the constant-velocity path times its bend.
void deskew(const TimedVoxels& v, const Eigen::Isometry3d& T_previous_current, double dt, bool current, std::vector<Eigen::Vector3f>* points,
            std::vector<Eigen::Vector3f>* normals, const std::optional<SweepIncrement>& velocity = std::nullopt, const SweepBend& bend = {}) {
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  const Eigen::Isometry3d T_current_previous = T_previous_current.inverse();
  const Eigen::Isometry3d& T_rate = velocity && !current ? velocity->T_start_end : T_previous_current;
  const double rate_dt = velocity && !current ? velocity->dt : dt;
  points->resize(v.points.size());
  normals->resize(v.points.size());
  for (std::size_t i = 0; i < v.points.size(); ++i) {
    const double tau = (current ? dt : 0.0) + v.time[i];
    const Eigen::Isometry3d P =
        bend.empty() ? interpolate_screw(I, T_rate, tau / rate_dt) : interpolate_screw(I, T_rate, tau / rate_dt) * bend.at(v.time[i]);
    const Eigen::Isometry3f T = (current ? T_current_previous * P : P).cast<float>();
    (*points)[i] = T * v.points[i];
    (*normals)[i] = T.linear() * v.normals[i];
  }
}

/// The current sweep's path with more than one turn rate, against the previous sweep deskewed under the final estimate.
void refine_shape(const TimedVoxels& cur, const TimedVoxels& prev, const Eigen::Isometry3d& T_previous_current, double dt,
                  const std::optional<SweepIncrement>& previous_velocity, const SweepMotionConfig& config, SweepMotionResult* r) {
  std::vector<Eigen::Vector3f> target, target_normals;
  deskew(prev, T_previous_current, dt, false, &target, &target_normals, previous_velocity);
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  const auto path = [&](double t) { return interpolate_screw(I, T_previous_current, (dt + t) / dt); };
  const SweepShapeResult s = refine_sweep_shape(cur.points, cur.time, path, target, target_normals, config.shape);
  r->shape_correction_deg = s.max_correction_deg;
  if (!s.refined) return;
  r->shape_refined = true;
  r->knot_times = s.knot_times;
  r->T_previous_knot = s.T_ref_knot;
  r->T_previous_current = s.T_ref_stamp;
}

}  // namespace

PointCloud sweep_motion_input(const PointCloud& cloud, const SweepMotionConfig& config) {
  PointCloud out;
  if (!cloud.has_time()) return out;
  const std::size_t stride = input_stride(cloud.size(), config.max_input_points);
  out.points.reserve(cloud.size() / stride + 1);
  out.time.reserve(cloud.size() / stride + 1);
  for (std::size_t i = 0; i < cloud.size(); i += stride) {
    out.points.push_back(cloud.points[i]);
    out.time.push_back(cloud.time[i]);
  }
  return out;
}

GicpConfig SweepMotionConfig::default_gicp() { return near_clouds_gicp(1500); }

std::optional<std::string> SweepMotionConfig::validate() const {
  if (!(voxel_size > 0.0)) return "voxel_size must be > 0";
  if (!(min_range >= 0.0 && max_range > min_range)) return "need 0 <= min_range < max_range";
  if (rounds < 1 || rounds > 10) return "rounds must be in [1, 10]";
  if (!(max_translation_change > 0.0) || !(max_rotation_change_deg > 0.0)) return "max_translation_change and max_rotation_change_deg must be > 0";
  if (!(max_degeneracy >= 1.0)) return "max_degeneracy must be >= 1";
  if (!(min_velocity_change_deg >= 0.0)) return "min_velocity_change_deg must be >= 0";
  if (!(min_fitness >= 0.0 && min_fitness <= 1.0)) return "min_fitness must be in [0, 1]";
  if (auto e = gicp.validate()) return "gicp: " + *e;
  return std::nullopt;
}

SweepMotionResult estimate_sweep_motion(const PointCloud& previous, const PointCloud& current, double dt,
                                        const Eigen::Isometry3d& odometry_T_previous_current, const SweepMotionConfig& config,
                                        const std::optional<SweepIncrement>& odometry_previous_sweep, const SweepBends& bends) {
  Stopwatch sw;
  SweepMotionResult r;
  r.T_previous_current = odometry_T_previous_current;
  const auto give_up = [&](std::string why) {
    r.T_previous_current = odometry_T_previous_current;
    r.refined = false;
    r.reason = std::move(why);
    r.ms = sw.ms();
    return r;
  };
  if (auto e = config.validate()) return give_up("invalid SweepMotionConfig: " + *e);
  if (!(dt > 0.0) || !std::isfinite(dt)) return give_up("no time between the sweeps");
  if (!previous.has_time() || !current.has_time()) return give_up("a sweep has no per-point times");
  const TimedVoxels prev = timed_voxels(previous, config);
  const TimedVoxels cur = timed_voxels(current, config);
  constexpr std::size_t kMinVoxels = 50;
  if (prev.points.size() < kMinVoxels || cur.points.size() < kMinVoxels) return give_up("too few points in range");
  // The odometry's change of turn rate between the sweeps, when it is more than its step noise.
  std::optional<Eigen::Isometry3d> change;
  double rate_change_deg = -1.0;  // unknown without the odometry's previous sweep
  if (odometry_previous_sweep && odometry_previous_sweep->dt > 0.0) {
    Eigen::Isometry3d c = Eigen::Isometry3d::Identity();
    c.linear() = odometry_T_previous_current.linear().transpose() * odometry_previous_sweep->T_start_end.linear();
    rate_change_deg = rotation_angle(c) * 180.0 / kPi;
    if (rate_change_deg > config.min_velocity_change_deg) change = c;
  }
  r.velocity_changed = change.has_value();
  // The odometry's own rotation over the previous sweep (its noise once, not the difference's twice).
  const auto previous_velocity = [&](const Eigen::Isometry3d& T) -> std::optional<SweepIncrement> {
    Eigen::Isometry3d V = T;
    V.linear() = bends.previous_rotation ? *bends.previous_rotation : odometry_previous_sweep->T_start_end.linear();
    return SweepIncrement{V, odometry_previous_sweep->dt};
  };
  Eigen::Isometry3d T = odometry_T_previous_current;
  if (bends.current_rotation) T.linear() = *bends.current_rotation;
  std::vector<Eigen::Vector3f> source, source_normals, target, target_normals;
  Eigen::Vector3d weakest = Eigen::Vector3d::Zero();
  for (int round = 0; round < config.rounds; ++round) {
    deskew(cur, T, dt, true, &source, &source_normals, std::nullopt, bends.current);
    deskew(prev, T, dt, false, &target, &target_normals,
           (change || (bends.previous_rotation && odometry_previous_sweep)) ? previous_velocity(T) : std::nullopt, bends.previous);
    const GicpResult g = align_gicp(source, source_normals, target, target_normals, T, config.gicp);
    r.iterations += g.iterations;
    r.fitness = g.fitness;
    r.degeneracy = g.degeneracy;
    if (!g.converged) return give_up("GICP did not converge: " + g.reason);
    T = g.T_target_source;
    weakest = g.weakest_direction;
  }
  // A direction the scans do not fix (a straight street seen by 16 rings, a tunnel: GICP slides along it): the
  // translation along that direction (the Hessian's weakest) is the odometry's, the rest the scans'. Their rotation
  // holds either way. (Solution remapping, Zhang, Kaess & Singh 2016: only the degenerate direction is replaced.)
  const bool degenerate = !(r.degeneracy >= 1.0 && r.degeneracy <= config.max_degeneracy);
  if (degenerate) {
    const Eigen::Vector3d d = T.linear() * weakest;  // the right perturbation's direction, in the previous stamp's frame
    if (std::isfinite(r.degeneracy) && d.allFinite() && d.norm() > 0.5) {
      r.weak_direction = d.normalized();
      r.weak_direction_from_odometry = true;
      T.translation() += r.weak_direction * r.weak_direction.dot(odometry_T_previous_current.translation() - T.translation());
    } else {  // no direction to keep (no information at all): the odometry's translation
      r.translation_from_odometry = true;
      T.translation() = odometry_T_previous_current.translation();
    }
  }
  r.translation_change = (T.translation() - odometry_T_previous_current.translation()).norm();
  r.rotation_change_deg = rotation_angle(odometry_T_previous_current.inverse() * T) * 180.0 / kPi;
  if (r.fitness < config.min_fitness) return give_up("GICP fitness " + std::to_string(r.fitness) + " below " + std::to_string(config.min_fitness));
  if (r.translation_change > config.max_translation_change || r.rotation_change_deg > config.max_rotation_change_deg)
    return give_up("the scans' increment is " + std::to_string(r.translation_change) + " m / " + std::to_string(r.rotation_change_deg) +
                   " deg from the odometry's");
  r.T_previous_current = T;
  r.refined = true;
  const bool rate_changed = rate_change_deg >= config.shape.min_rate_change_deg;  // never when unknown (-1 < 0 <= min)
  r.bent = !bends.current.empty();
  if (!r.bent && !degenerate && config.shape.segments > 0 && rate_changed)
    refine_shape(cur, prev, T, dt, change ? previous_velocity(T) : std::nullopt, config, &r);
  r.ms = sw.ms();
  return r;
}

}  // namespace loopd
