#include "loopd/registration/gicp.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "loopd/base/kdtree.hpp"
#include "loopd/base/stopwatch.hpp"

namespace loopd {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// Points per reduction block: the per-point sums are added in blocks of this size, then the blocks in order, so the
/// floating-point result does not depend on the number of threads or on scheduling.
constexpr int kBlockSize = 128;
/// Fewer neighbours than this give no usable plane estimate; such points get an isotropic covariance.
constexpr int kMinCovarianceNeighbors = 4;
constexpr int kMaxNeighbors = 64;
constexpr int kMinPoints = 10;

/// Copies the finite points (and their normals, when given) in step.
void finite_points(const std::vector<Eigen::Vector3f>& in, const std::vector<Eigen::Vector3f>& normals_in, std::vector<Eigen::Vector3f>* out,
                   std::vector<Eigen::Vector3f>* normals_out) {
  out->reserve(in.size());
  const bool has_normals = normals_in.size() == in.size();
  for (std::size_t i = 0; i < in.size(); ++i) {
    if (!in[i].allFinite()) continue;
    out->push_back(in[i]);
    if (has_normals) normals_out->push_back(normals_in[i].allFinite() ? normals_in[i] : Eigen::Vector3f::Zero());
  }
}

/// Ren 2019, Eq. (2): normal = eigenvector of the smallest eigenvalue of the k-neighbour covariance.
/// Normals at `queries` from neighbours among `points` (indexed by `tree`).
std::vector<Eigen::Vector3f> estimate_normals(const std::vector<Eigen::Vector3f>& queries, const std::vector<Eigen::Vector3f>& points,
                                              const KdTree3f& tree, int k, int num_threads) {
  std::vector<Eigen::Vector3f> normals(queries.size(), Eigen::Vector3f::Zero());
  const int n = static_cast<int>(queries.size());
#pragma omp parallel for num_threads(num_threads) schedule(dynamic, 128)
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = queries[static_cast<std::size_t>(i)];
    if (!p.allFinite()) continue;
    int idx[kMaxNeighbors];
    float d2[kMaxNeighbors];
    const int found = tree.knn(p, k, idx, d2);
    if (found < kMinCovarianceNeighbors) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int j = 0; j < found; ++j) mean += points[static_cast<std::size_t>(idx[j])].cast<double>();
    mean /= found;
    Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
    for (int j = 0; j < found; ++j) {
      const Eigen::Vector3d d = points[static_cast<std::size_t>(idx[j])].cast<double>() - mean;
      c.noalias() += d * d.transpose();
    }
    c /= found;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(c);
    const Eigen::Vector3d normal = es.eigenvectors().col(0);  // eigenvalues ascending
    if (normal.allFinite() && normal.norm() > 0.5) normals[static_cast<std::size_t>(i)] = normal.normalized().cast<float>();
  }
  return normals;
}

/// Ren 2019, Eq. (3): C = U diag(eps, 1, 1) U^T = I - (1 - eps) n n^T; a zero normal gives the identity.
std::vector<Eigen::Matrix3d> covariances_from_normals(const std::vector<Eigen::Vector3f>& normals, double eps) {
  std::vector<Eigen::Matrix3d> covs(normals.size());
  for (std::size_t i = 0; i < normals.size(); ++i) {
    const Eigen::Vector3d n = normals[i].cast<double>();
    const double len2 = n.squaredNorm();
    covs[i] = Eigen::Matrix3d::Identity();
    if (len2 > 0.25 && std::isfinite(len2)) covs[i] -= (1.0 - eps) * (n * n.transpose()) / len2;
  }
  return covs;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

struct Linearization {
  Matrix6d H = Matrix6d::Zero();
  Vector6d b = Vector6d::Zero();
  double cost = 0;
  double sum_distance = 0;
  int inliers = 0;
  void add(const Linearization& o) {
    H += o.H;
    b += o.b;
    cost += o.cost;
    sum_distance += o.sum_distance;
    inliers += o.inliers;
  }
};

/// One Gauss-Newton linearisation of Ren 2019 Eq. (6) at T with correspondences within max_distance.
/// Error e_i = T s_i - q_i, M_i = (C_q + R C_s R^T)^-1, right perturbation T * Exp(w, v):
/// de/dw = -R [s]x, de/dv = R.
Linearization linearize(const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Matrix3d>& source_covs,
                        const std::vector<Eigen::Vector3f>& target, const std::vector<Eigen::Matrix3d>& target_covs, const KdTree3f& target_tree,
                        const Eigen::Isometry3d& T, double max_distance, int num_threads) {
  const int n = static_cast<int>(source.size());
  const int num_blocks = (n + kBlockSize - 1) / kBlockSize;
  std::vector<Linearization> blocks(static_cast<std::size_t>(num_blocks));
  const Eigen::Matrix3d R = T.linear();
  const float max_d2 = static_cast<float>(max_distance * max_distance);
  const Eigen::Isometry3f Tf = T.cast<float>();
#pragma omp parallel for num_threads(num_threads) schedule(dynamic, 2)
  for (int blk = 0; blk < num_blocks; ++blk) {
    Linearization& L = blocks[static_cast<std::size_t>(blk)];
    const int end = std::min(n, (blk + 1) * kBlockSize);
    for (int i = blk * kBlockSize; i < end; ++i) {
      const auto si = static_cast<std::size_t>(i);
      int j = -1;
      float d2 = 0.f;
      if (!target_tree.nearest(Tf * source[si], &j, &d2) || d2 > max_d2) continue;
      const auto sj = static_cast<std::size_t>(j);
      const Eigen::Vector3d s = source[si].cast<double>();
      const Eigen::Vector3d e = T * s - target[sj].cast<double>();
      const Eigen::Matrix3d C = target_covs[sj] + R * source_covs[si] * R.transpose();
      const Eigen::Matrix3d M = C.inverse();
      Eigen::Matrix<double, 3, 6> J;
      J.leftCols<3>() = -R * skew(s);
      J.rightCols<3>() = R;
      const Eigen::Matrix<double, 6, 3> JtM = J.transpose() * M;
      L.H.noalias() += JtM * J;
      L.b.noalias() += JtM * e;
      L.cost += e.dot(M * e);
      L.sum_distance += std::sqrt(static_cast<double>(d2));
      ++L.inliers;
    }
  }
  Linearization total;
  for (const auto& L : blocks) total.add(L);  // fixed order: deterministic
  return total;
}

Eigen::Isometry3d exp_update(const Vector6d& delta) {
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d w = delta.head<3>();
  const double angle = w.norm();
  if (angle > 1e-12) D.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  D.translation() = delta.tail<3>();
  return D;
}

/// The reason align_gicp refuses its inputs before any work (config, initial transform, normals' sizes).
std::optional<std::string> input_error(const std::vector<Eigen::Vector3f>& source_in, const std::vector<Eigen::Vector3f>& source_normals_in,
                                       const std::vector<Eigen::Vector3f>& target_in, const std::vector<Eigen::Vector3f>& target_normals_in,
                                       const Eigen::Isometry3d& init_T_target_source, const GicpConfig& config) {
  if (auto err = config.validate()) return err;
  if (!init_T_target_source.matrix().allFinite()) return "initial transform is not finite";
  if ((!source_normals_in.empty() && source_normals_in.size() != source_in.size()) ||
      (!target_normals_in.empty() && target_normals_in.size() != target_in.size()))
    return "normals must be empty or sized like their points";
  return std::nullopt;
}

std::string too_few_points(std::size_t source_size, std::size_t target_size) {
  std::ostringstream os;
  os << "too few finite points (source " << source_size << ", target " << target_size << ", need " << kMinPoints << ")";
  return os.str();
}

/// The source points the iterations use, with their normals (empty: to be estimated).
struct SourceSample {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> normals;
};

/// Optional deterministic stride subsample of the source: fewer correspondences per iteration; the normals of the
/// kept points still come from their neighbours in the full source.
SourceSample stride_subsample(const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& source_normals, int max_source_points) {
  SourceSample used{source, source_normals};
  if (max_source_points > 0 && source.size() > static_cast<std::size_t>(max_source_points)) {
    const double stride = static_cast<double>(source.size()) / max_source_points;
    used.points.clear();
    used.normals.clear();
    for (int k = 0; k < max_source_points; ++k) {
      const auto i = static_cast<std::size_t>(k * stride);
      used.points.push_back(source[i]);
      if (!source_normals.empty()) used.normals.push_back(source_normals[i]);
    }
  }
  return used;
}

/// Ren 2019, Eq. (3) for the source sample: from its given normals, or from normals estimated on its neighbours in
/// the full source.
std::vector<Eigen::Matrix3d> source_covariances(const std::vector<Eigen::Vector3f>& source, const SourceSample& used, const GicpConfig& config) {
  if (!used.normals.empty()) return covariances_from_normals(used.normals, config.epsilon);
  const KdTree3f source_tree(source);
  return covariances_from_normals(estimate_normals(used.points, source, source_tree, config.k_neighbors, config.num_threads), config.epsilon);
}

/// Ren 2019, Eq. (3) for the target: from its given normals, or from normals estimated on its neighbours.
std::vector<Eigen::Matrix3d> target_covariances(const std::vector<Eigen::Vector3f>& target, const std::vector<Eigen::Vector3f>& target_normals,
                                                const KdTree3f& target_tree, const GicpConfig& config) {
  if (!target_normals.empty()) return covariances_from_normals(target_normals, config.epsilon);
  return covariances_from_normals(estimate_normals(target, target, target_tree, config.k_neighbors, config.num_threads), config.epsilon);
}

/// What every linearisation reads: the source sample and the target, their covariances and the target tree.
struct GicpClouds {
  const std::vector<Eigen::Vector3f>& source;
  const std::vector<Eigen::Matrix3d>& source_covs;
  const std::vector<Eigen::Vector3f>& target;
  const std::vector<Eigen::Matrix3d>& target_covs;
  const KdTree3f& target_tree;
};

/// Damped Gauss-Newton step: solves (H + damping * max(diag H) I) delta = -b.
Vector6d gauss_newton_step(const Linearization& L, double damping) {
  Matrix6d A = L.H;
  A.diagonal().array() += damping * std::max(1e-12, L.H.diagonal().maxCoeff());
  return A.ldlt().solve(-L.b);
}

/// T <- T * Exp(delta), right perturbation.
void apply_update(const Vector6d& delta, Eigen::Isometry3d* T) {
  *T = *T * exp_update(delta);
  // Keep the rotation orthonormal over many small updates.
  const Eigen::Quaterniond q(T->linear());
  T->linear() = q.normalized().toRotationMatrix();
}

/// Where the correspondence-distance schedule ended.
struct ScheduleOutcome {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  bool last_stage_converged = false;
  bool numeric_failure = false;
};

/// Gauss-Newton from init, one stage per entry of the correspondence-distance schedule; counts the iterations.
ScheduleOutcome run_schedule(const GicpClouds& c, const Eigen::Isometry3d& init, const GicpConfig& config, int* iterations) {
  ScheduleOutcome out;
  out.T = init;
  for (std::size_t stage = 0; stage < config.max_correspondence_distances.size() && !out.numeric_failure; ++stage) {
    const double max_distance = config.max_correspondence_distances[stage];
    const bool final_stage = stage + 1 == config.max_correspondence_distances.size();
    // Coarse stages only need to hand a good start to the next one: 10x looser step criterion.
    const double loosen = final_stage ? 1.0 : 10.0;
    out.last_stage_converged = false;
    for (int it = 0; it < config.max_iterations; ++it) {
      const Linearization L = linearize(c.source, c.source_covs, c.target, c.target_covs, c.target_tree, out.T, max_distance, config.num_threads);
      ++*iterations;
      if (L.inliers < 6) break;  // nothing to pull on at this distance; the next stage (or the final check) decides
      const Vector6d delta = gauss_newton_step(L, config.damping);
      if (!delta.allFinite()) {
        out.numeric_failure = true;
        break;
      }
      apply_update(delta, &out.T);
      if (delta.head<3>().norm() < loosen * config.convergence_rotation && delta.tail<3>().norm() < loosen * config.convergence_translation) {
        out.last_stage_converged = true;
        break;
      }
    }
  }
  return out;
}

/// Final evaluation at the final transform: residual, fitness and the Hessian used as loop-edge information.
void evaluate_final(const GicpClouds& c, const Eigen::Isometry3d& T, const GicpConfig& config, GicpResult* result) {
  const double final_distance = config.max_correspondence_distances.back();
  const Linearization F = linearize(c.source, c.source_covs, c.target, c.target_covs, c.target_tree, T, final_distance, config.num_threads);
  result->T_target_source = T;
  result->H = F.H;
  result->cost = F.cost;
  result->num_inliers = F.inliers;
  result->fitness = static_cast<double>(F.inliers) / static_cast<double>(c.source.size());
  result->residual = F.inliers > 0 ? F.sum_distance / F.inliers : -1.0;
  result->degeneracy = F.inliers > 0 ? gicp_degeneracy(F.H, &result->weakest_direction) : -1.0;
}

/// Why the result is not converged; empty when it is.
std::string failure_reason(const ScheduleOutcome& schedule, double fitness, const GicpConfig& config) {
  std::ostringstream why;
  if (schedule.numeric_failure) {
    why << "numerical failure (non-finite update)";
  } else if (!schedule.last_stage_converged) {
    why << "no convergence within " << config.max_iterations << " iterations in the last stage";
  } else if (fitness < config.min_fitness) {
    why << "stalled at low fitness " << fitness << " < " << config.min_fitness;
  }
  return why.str();
}

}  // namespace

GicpConfig near_clouds_gicp(int max_source_points) {
  GicpConfig g;
  g.max_correspondence_distances = {1.0, 0.5};
  g.max_source_points = max_source_points;
  g.num_threads = 1;
  g.min_fitness = 0.3;
  return g;
}

std::optional<std::string> GicpConfig::validate() const {
  if (k_neighbors < kMinCovarianceNeighbors || k_neighbors > kMaxNeighbors)
    return "GicpConfig.k_neighbors must be in [" + std::to_string(kMinCovarianceNeighbors) + ", " + std::to_string(kMaxNeighbors) + "]";
  if (!(epsilon > 0.0 && epsilon < 1.0)) return "GicpConfig.epsilon must be in (0, 1)";
  if (max_correspondence_distances.empty()) return "GicpConfig.max_correspondence_distances must not be empty";
  for (double d : max_correspondence_distances)
    if (!(d > 0.0) || !std::isfinite(d)) return "GicpConfig.max_correspondence_distances must be positive and finite";
  if (max_iterations < 1) return "GicpConfig.max_iterations must be >= 1";
  if (!(convergence_translation > 0.0) || !(convergence_rotation > 0.0)) return "GicpConfig convergence thresholds must be positive";
  if (!(damping >= 0.0)) return "GicpConfig.damping must be >= 0";
  if (!(min_fitness >= 0.0 && min_fitness <= 1.0)) return "GicpConfig.min_fitness must be in [0, 1]";
  if (num_threads < 1) return "GicpConfig.num_threads must be >= 1";
  if (max_source_points != 0 && max_source_points < kMinPoints) return "GicpConfig.max_source_points must be 0 or >= 10";
  return std::nullopt;
}

double gicp_degeneracy(const Eigen::Matrix<double, 6, 6>& H, Eigen::Vector3d* weakest) {
  if (!H.allFinite()) return std::numeric_limits<double>::infinity();
  const Eigen::Matrix3d Hrr = H.topLeftCorner<3, 3>();
  const Eigen::Matrix3d Hrt = H.topRightCorner<3, 3>();
  const Eigen::Matrix3d Htt = H.bottomRightCorner<3, 3>();
  Eigen::LDLT<Eigen::Matrix3d> ldlt(Hrr);
  Eigen::Matrix3d S = Htt;
  if (ldlt.info() == Eigen::Success && ldlt.isPositive() && ldlt.vectorD().minCoeff() > 0.0) S = Htt - Hrt.transpose() * ldlt.solve(Hrt);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(0.5 * (S + S.transpose()));
  const Eigen::Vector3d ev = es.eigenvalues();
  if (weakest) *weakest = es.eigenvectors().col(0);
  if (!(ev(0) > 0.0) || !std::isfinite(ev(2))) return std::numeric_limits<double>::infinity();
  return ev(2) / ev(0);
}

std::vector<Eigen::Vector3f> estimate_gicp_normals(const std::vector<Eigen::Vector3f>& points, int k_neighbors, int num_threads) {
  k_neighbors = std::clamp(k_neighbors, kMinCovarianceNeighbors, kMaxNeighbors);
  // Build the tree over the finite points only; map the normals back.
  std::vector<Eigen::Vector3f> finite;
  std::vector<Eigen::Vector3f> unused;
  finite_points(points, {}, &finite, &unused);
  std::vector<Eigen::Vector3f> out(points.size(), Eigen::Vector3f::Zero());
  if (finite.empty()) return out;
  const KdTree3f tree(finite);
  const std::vector<Eigen::Vector3f> fn = estimate_normals(finite, finite, tree, k_neighbors, std::max(1, num_threads));
  std::size_t k = 0;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (points[i].allFinite()) out[i] = fn[k++];
  return out;
}

GicpResult align_gicp(const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& target,
                      const Eigen::Isometry3d& init_T_target_source, const GicpConfig& config) {
  return align_gicp(source, {}, target, {}, init_T_target_source, config);
}

GicpResult align_gicp(const std::vector<Eigen::Vector3f>& source_in, const std::vector<Eigen::Vector3f>& source_normals_in,
                      const std::vector<Eigen::Vector3f>& target_in, const std::vector<Eigen::Vector3f>& target_normals_in,
                      const Eigen::Isometry3d& init_T_target_source, const GicpConfig& config) {
  Stopwatch sw;
  GicpResult result;
  result.T_target_source = init_T_target_source;
  if (auto err = input_error(source_in, source_normals_in, target_in, target_normals_in, init_T_target_source, config)) {
    result.reason = *err;
    return result;
  }
  std::vector<Eigen::Vector3f> source, target, source_normals, target_normals;
  finite_points(source_in, source_normals_in, &source, &source_normals);
  finite_points(target_in, target_normals_in, &target, &target_normals);
  if (static_cast<int>(source.size()) < kMinPoints || static_cast<int>(target.size()) < kMinPoints) {
    result.reason = too_few_points(source.size(), target.size());
    result.ms = sw.ms();
    return result;
  }

  // Per-point covariances (Ren 2019, Eq. 3) of the source sample and of the target.
  const KdTree3f target_tree(target);
  const SourceSample used = stride_subsample(source, source_normals, config.max_source_points);
  const std::vector<Eigen::Matrix3d> source_covs = source_covariances(source, used, config);
  const std::vector<Eigen::Matrix3d> target_covs = target_covariances(target, target_normals, target_tree, config);
  result.ms_covariances = sw.ms();

  // Gauss-Newton on Eq. (6) over the distance schedule, then the final evaluation.
  const GicpClouds clouds{used.points, source_covs, target, target_covs, target_tree};
  const ScheduleOutcome schedule = run_schedule(clouds, init_T_target_source, config, &result.iterations);
  evaluate_final(clouds, schedule.T, config, &result);
  result.reason = failure_reason(schedule, result.fitness, config);
  result.converged = result.reason.empty();
  result.ms = sw.ms();
  return result;
}

}  // namespace loopd
