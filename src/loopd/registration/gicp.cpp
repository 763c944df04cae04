#include "loopd/registration/gicp.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "loopd/core/kdtree.hpp"
#include "loopd/core/stopwatch.hpp"

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
std::vector<Eigen::Vector3f> estimate_normals(const std::vector<Eigen::Vector3f>& queries, const std::vector<Eigen::Vector3f>& points, const KdTree3f& tree, int k,
                                              int num_threads) {
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
                        const std::vector<Eigen::Vector3f>& target, const std::vector<Eigen::Matrix3d>& target_covs,
                        const KdTree3f& target_tree, const Eigen::Isometry3d& T, double max_distance, int num_threads) {
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

}  // namespace

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
  if (auto err = config.validate()) {
    result.reason = *err;
    return result;
  }
  if (!init_T_target_source.matrix().allFinite()) {
    result.reason = "initial transform is not finite";
    return result;
  }
  if ((!source_normals_in.empty() && source_normals_in.size() != source_in.size()) ||
      (!target_normals_in.empty() && target_normals_in.size() != target_in.size())) {
    result.reason = "normals must be empty or sized like their points";
    return result;
  }
  std::vector<Eigen::Vector3f> source, target, source_normals, target_normals;
  finite_points(source_in, source_normals_in, &source, &source_normals);
  finite_points(target_in, target_normals_in, &target, &target_normals);
  if (static_cast<int>(source.size()) < kMinPoints || static_cast<int>(target.size()) < kMinPoints) {
    std::ostringstream os;
    os << "too few finite points (source " << source.size() << ", target " << target.size() << ", need " << kMinPoints << ")";
    result.reason = os.str();
    result.ms = sw.ms();
    return result;
  }

  const KdTree3f target_tree(target);
  // Optional deterministic stride subsample of the source: fewer correspondences per iteration; the normals of the
  // kept points still come from their neighbours in the full source.
  std::vector<Eigen::Vector3f> source_used = source, source_used_normals = source_normals;
  if (config.max_source_points > 0 && source.size() > static_cast<std::size_t>(config.max_source_points)) {
    const double stride = static_cast<double>(source.size()) / config.max_source_points;
    source_used.clear();
    source_used_normals.clear();
    for (int k = 0; k < config.max_source_points; ++k) {
      const auto i = static_cast<std::size_t>(k * stride);
      source_used.push_back(source[i]);
      if (!source_normals.empty()) source_used_normals.push_back(source_normals[i]);
    }
  }
  if (source_used_normals.empty()) {
    const KdTree3f source_tree(source);
    source_used_normals = estimate_normals(source_used, source, source_tree, config.k_neighbors, config.num_threads);
  }
  if (target_normals.empty()) target_normals = estimate_normals(target, target, target_tree, config.k_neighbors, config.num_threads);
  const std::vector<Eigen::Matrix3d> source_covs = covariances_from_normals(source_used_normals, config.epsilon);
  const std::vector<Eigen::Matrix3d> target_covs = covariances_from_normals(target_normals, config.epsilon);
  result.ms_covariances = sw.ms();

  Eigen::Isometry3d T = init_T_target_source;
  bool last_stage_converged = false;
  bool numeric_failure = false;
  for (std::size_t stage = 0; stage < config.max_correspondence_distances.size() && !numeric_failure; ++stage) {
    const double max_distance = config.max_correspondence_distances[stage];
    const bool final_stage = stage + 1 == config.max_correspondence_distances.size();
    // Coarse stages only need to hand a good start to the next one: 10x looser step criterion.
    const double loosen = final_stage ? 1.0 : 10.0;
    last_stage_converged = false;
    for (int it = 0; it < config.max_iterations; ++it) {
      const Linearization L = linearize(source_used, source_covs, target, target_covs, target_tree, T, max_distance, config.num_threads);
      ++result.iterations;
      if (L.inliers < 6) break;  // nothing to pull on at this distance; the next stage (or the final check) decides
      Matrix6d A = L.H;
      A.diagonal().array() += config.damping * std::max(1e-12, L.H.diagonal().maxCoeff());
      const Vector6d delta = A.ldlt().solve(-L.b);
      if (!delta.allFinite()) {
        numeric_failure = true;
        break;
      }
      T = T * exp_update(delta);
      // Keep the rotation orthonormal over many small updates.
      const Eigen::Quaterniond q(T.linear());
      T.linear() = q.normalized().toRotationMatrix();
      if (delta.head<3>().norm() < loosen * config.convergence_rotation && delta.tail<3>().norm() < loosen * config.convergence_translation) {
        last_stage_converged = true;
        break;
      }
    }
  }

  // Final evaluation at the final transform: residual, fitness and the Hessian used as loop-edge information.
  const double final_distance = config.max_correspondence_distances.back();
  const Linearization F = linearize(source_used, source_covs, target, target_covs, target_tree, T, final_distance, config.num_threads);
  result.T_target_source = T;
  result.H = F.H;
  result.cost = F.cost;
  result.num_inliers = F.inliers;
  result.fitness = static_cast<double>(F.inliers) / static_cast<double>(source_used.size());
  result.residual = F.inliers > 0 ? F.sum_distance / F.inliers : -1.0;
  result.degeneracy = F.inliers > 0 ? gicp_degeneracy(F.H, &result.weakest_direction) : -1.0;

  std::ostringstream why;
  if (numeric_failure) {
    why << "numerical failure (non-finite update)";
  } else if (!last_stage_converged) {
    why << "no convergence within " << config.max_iterations << " iterations in the last stage";
  } else if (result.fitness < config.min_fitness) {
    why << "stalled at low fitness " << result.fitness << " < " << config.min_fitness;
  }
  result.reason = why.str();
  result.converged = result.reason.empty();
  result.ms = sw.ms();
  return result;
}

}  // namespace loopd
