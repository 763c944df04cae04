// The Ceres side of the pose graph (Ren 2019, Sec. 3.4): parameters, residual blocks, manifolds, graduated solve.
#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "loopd/correction/pose_graph_internal.hpp"

namespace loopd {
namespace detail {
namespace {

/// Relative-pose edge a -> b: residual = sqrt_info * [R_z^T (t_ab - t_z); 2 vec(q_z^-1 q_ab)], both a right
/// perturbation of the measurement Z (in frame b), ordering (t, r).
struct RelativePoseError {
  RelativePoseError(const Eigen::Isometry3d& Z, const Matrix6d& sqrt_info)
      : p_z(Z.translation()), q_z(Eigen::Quaterniond(Z.linear()).normalized()), sqrt_info(sqrt_info) {}

  template <typename T>
  bool operator()(const T* pa, const T* qa, const T* pb, const T* qb, T* out) const {
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> Pa(pa), Pb(pb);
    Eigen::Map<const Eigen::Quaternion<T>> Qa(qa), Qb(qb);
    const Eigen::Quaternion<T> Qa_inv = Qa.conjugate();
    const Eigen::Quaternion<T> Qz_inv = q_z.conjugate().template cast<T>();
    const Eigen::Quaternion<T> dq = Qz_inv * (Qa_inv * Qb);
    const Eigen::Matrix<T, 3, 1> dp = Qz_inv * (Qa_inv * (Pb - Pa) - p_z.template cast<T>());
    Eigen::Matrix<T, 6, 1> r;
    r.template head<3>() = dp;
    r.template tail<3>() = T(2.0) * dq.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> res(out);
    res = sqrt_info.template cast<T>() * r;
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Isometry3d& Z, const Matrix6d& sqrt_info) {
    return new ceres::AutoDiffCostFunction<RelativePoseError, 6, 3, 4, 3, 4>(new RelativePoseError(Z, sqrt_info));
  }

  Eigen::Vector3d p_z;
  Eigen::Quaterniond q_z;
  Matrix6d sqrt_info;
};

/// Ren 2019, Sec. 3.4.2, Eqs. (9)-(11): the world plane node (n_w, d_w) expressed in the sensor frame,
/// n_s = R^T n_w, d_s = d_w + n_w . t, compared with the plane observed in that frame. We compare the normal vectors
/// directly (instead of Ren's two angles, which are singular for a horizontal plane) plus the offset.
struct PlaneError {
  PlaneError(const Eigen::Vector4d& obs, double sigma_n, double sigma_d) : obs(obs), inv_n(1.0 / sigma_n), inv_d(1.0 / sigma_d) {}

  template <typename T>
  bool operator()(const T* p, const T* q, const T* n_w, const T* d_w, T* out) const {
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> P(p), N(n_w);
    Eigen::Map<const Eigen::Quaternion<T>> Q(q);
    const Eigen::Matrix<T, 3, 1> n_s = Q.conjugate() * N;
    const T d_s = d_w[0] + N.dot(P);
    for (int k = 0; k < 3; ++k) out[k] = T(inv_n) * (n_s[k] - T(obs[k]));
    out[3] = T(inv_d) * (d_s - T(obs[3]));
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Vector4d& obs, double sigma_n, double sigma_d) {
    return new ceres::AutoDiffCostFunction<PlaneError, 4, 3, 4, 3, 1>(new PlaneError(obs, sigma_n, sigma_d));
  }

  Eigen::Vector4d obs;
  double inv_n, inv_d;
};

ceres::LossFunction* make_loss(RobustLoss kind, double scale) {
  switch (kind) {
    case RobustLoss::kHuber:
      return new ceres::HuberLoss(scale);
    case RobustLoss::kCauchy:
      return new ceres::CauchyLoss(scale);
    case RobustLoss::kNone:
      break;
  }
  return nullptr;
}

/// @brief Solver parameters: position (3) and Eigen quaternion (x, y, z, w) per node.
struct NodeParameters {
  std::vector<double> p, q;
};

NodeParameters node_parameters(const std::vector<Eigen::Isometry3d>& poses) {
  const std::size_t n = poses.size();
  NodeParameters x{std::vector<double>(3 * n), std::vector<double>(4 * n)};
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Map<Eigen::Vector3d> pi(&x.p[3 * i]);
    pi = poses[i].translation();
    Eigen::Map<Eigen::Quaterniond> qi(&x.q[4 * i]);
    qi = Eigen::Quaterniond(poses[i].linear()).normalized();
  }
  return x;
}

/// @brief One relative-pose residual per edge, in edge order; loop edges get `loop_loss` (unless the config has no
/// robust kernel). Returns those robust residual blocks.
std::vector<ceres::ResidualBlockId> add_edge_residuals(ceres::Problem& problem, const std::vector<GraphEdge>& edges, const PoseGraphConfig& config,
                                                       ceres::LossFunctionWrapper& loop_loss, NodeParameters& x) {
  std::vector<ceres::ResidualBlockId> robust_blocks;
  for (const GraphEdge& e : edges) {
    const auto a = static_cast<std::size_t>(e.a), b = static_cast<std::size_t>(e.b);
    const bool robust = e.robust && config.loop_loss != RobustLoss::kNone;
    auto id = problem.AddResidualBlock(RelativePoseError::create(e.Z, e.sqrt_info), robust ? &loop_loss : nullptr, &x.p[3 * a], &x.q[4 * a],
                                       &x.p[3 * b], &x.q[4 * b]);
    if (robust) robust_blocks.push_back(id);
  }
  return robust_blocks;
}

/// @brief Plane nodes (Ren 2019, Sec. 3.4.2): a unit normal and an offset in the world frame per plane_id.
struct PlaneNodes {
  std::map<int, std::size_t> slot;  ///< plane_id -> node
  std::vector<double> storage;      ///< 4 per node: n_w (x, y, z), d_w
};

/// @brief Plane nodes initialised from the first observation of each plane.
PlaneNodes init_plane_nodes(const std::vector<Eigen::Isometry3d>& poses, const std::vector<PlaneObservation>& planes) {
  const std::size_t n = poses.size();
  PlaneNodes nodes;
  for (const PlaneObservation& o : planes) {
    if (!in_range(o.index, n) || nodes.slot.count(o.plane_id)) continue;
    const Eigen::Isometry3d& T = poses[static_cast<std::size_t>(o.index)];
    const Eigen::Vector3d n_w = (T.linear() * o.plane_sensor.head<3>()).normalized();
    nodes.slot[o.plane_id] = nodes.storage.size() / 4;
    nodes.storage.insert(nodes.storage.end(),
                         {n_w.x(), n_w.y(), n_w.z(), o.plane_sensor[3] / o.plane_sensor.head<3>().norm() - n_w.dot(T.translation())});
  }
  return nodes;
}

/// @brief Ren 2019, Sec. 3.4.2, Eqs. (9)-(11): one residual per plane observation, in observation order; the plane
/// normals stay unit vectors.
void add_plane_residuals(ceres::Problem& problem, const std::vector<PlaneObservation>& planes, std::size_t n, const PoseGraphConfig& config,
                         PlaneNodes& nodes, NodeParameters& x, ceres::SphereManifold<3>& sphere_manifold) {
  for (const PlaneObservation& o : planes) {
    if (!in_range(o.index, n)) continue;
    const std::size_t s = nodes.slot.at(o.plane_id);
    const Eigen::Vector4d obs = o.plane_sensor / o.plane_sensor.head<3>().norm();
    const auto i = static_cast<std::size_t>(o.index);
    problem.AddResidualBlock(PlaneError::create(obs, config.plane_normal_sigma, config.plane_distance_sigma), nullptr, &x.p[3 * i], &x.q[4 * i],
                             &nodes.storage[4 * s], &nodes.storage[4 * s + 3]);
  }
  for (std::size_t s = 0; s < nodes.slot.size(); ++s) problem.SetManifold(&nodes.storage[4 * s], &sphere_manifold);
}

/// @brief Quaternion manifold on every node's rotation; node 0 held fixed (the gauge).
void set_manifolds_and_gauge(ceres::Problem& problem, std::size_t n, ceres::EigenQuaternionManifold& quaternion_manifold, NodeParameters& x) {
  for (std::size_t i = 0; i < n; ++i)
    if (problem.HasParameterBlock(&x.q[4 * i])) problem.SetManifold(&x.q[4 * i], &quaternion_manifold);
  if (problem.HasParameterBlock(&x.p[0])) {
    problem.SetParameterBlockConstant(&x.p[0]);  // gauge: the first keyframe stays where it is
    problem.SetParameterBlockConstant(&x.q[0]);
  }
}

ceres::Solver::Options solver_options(const PoseGraphConfig& config) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = config.max_iterations;
  options.function_tolerance = config.function_tolerance;
  options.num_threads = config.num_threads;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  return options;
}

/// @brief Graduated kernel: when loops start far from satisfied (raw odometry start), a tight kernel would ignore them
/// all. Returns the loop kernel scales to solve with, in order.
std::vector<double> loop_kernel_scales(const ceres::Problem& problem, const std::vector<ceres::ResidualBlockId>& robust_blocks,
                                       const PoseGraphConfig& config) {
  std::vector<double> scales{config.loop_loss_scale};
  if (config.graduated && !robust_blocks.empty()) {
    double worst = 0.0;
    for (auto id : robust_blocks) {
      double cost = 0.0;
      problem.EvaluateResidualBlock(id, false, &cost, nullptr, nullptr);  // without the loss: 0.5 |r|^2
      worst = std::max(worst, std::sqrt(2.0 * cost));
    }
    if (worst > 10.0 * config.loop_loss_scale) {
      scales.clear();
      for (double f = config.graduated_start_factor; f > 1.0; f /= 10.0) scales.push_back(config.loop_loss_scale * f);
      scales.push_back(config.loop_loss_scale);
    }
  }
  return scales;
}

/// @brief One solve per kernel scale, each starting where the previous one ended; stops at a solver failure.
void solve_stages(ceres::Problem& problem, const ceres::Solver::Options& options, const std::vector<double>& scales, const PoseGraphConfig& config,
                  ceres::LossFunctionWrapper& loop_loss, PoseGraphResult& result) {
  bool first = true;
  result.converged = true;
  for (double scale : scales) {
    loop_loss.Reset(make_loss(config.loop_loss, scale), ceres::TAKE_OWNERSHIP);
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    if (first) result.initial_cost = summary.initial_cost;
    first = false;
    result.final_cost = summary.final_cost;
    result.iterations += static_cast<int>(summary.iterations.size());
    result.converged = result.converged && summary.termination_type == ceres::CONVERGENCE;
    result.message = summary.BriefReport();
    if (summary.termination_type == ceres::FAILURE) {
      result.converged = false;
      break;
    }
  }
}

/// @brief The solved parameters back into `poses` and result.planes.
void read_back(const NodeParameters& x, const PlaneNodes& plane_nodes, std::vector<Eigen::Isometry3d>& poses, PoseGraphResult& result) {
  for (std::size_t i = 0; i < poses.size(); ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::Map<const Eigen::Quaterniond>(&x.q[4 * i]).normalized().toRotationMatrix();
    T.translation() = Eigen::Map<const Eigen::Vector3d>(&x.p[3 * i]);
    poses[i] = T;
  }
  result.planes.clear();
  for (std::size_t s = 0; s < plane_nodes.slot.size(); ++s)
    result.planes.emplace_back(Eigen::Map<const Eigen::Vector4d>(&plane_nodes.storage[4 * s]));
}

}  // namespace

void solve_graph(std::vector<Eigen::Isometry3d>& poses, const std::vector<GraphEdge>& edges, const std::vector<PlaneObservation>& planes,
                 const PoseGraphConfig& config, PoseGraphResult& result) {
  const std::size_t n = poses.size();
  NodeParameters x = node_parameters(poses);

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::EigenQuaternionManifold quaternion_manifold;
  ceres::SphereManifold<3> sphere_manifold;

  // Loop edges get a robust kernel whose scale can change between solves (graduated kernel).
  ceres::LossFunctionWrapper loop_loss(make_loss(config.loop_loss, config.loop_loss_scale), ceres::TAKE_OWNERSHIP);
  const std::vector<ceres::ResidualBlockId> robust_blocks = add_edge_residuals(problem, edges, config, loop_loss, x);
  PlaneNodes plane_nodes;
  if (config.use_plane_constraints) {
    plane_nodes = init_plane_nodes(poses, planes);
    add_plane_residuals(problem, planes, n, config, plane_nodes, x, sphere_manifold);
  }
  set_manifolds_and_gauge(problem, n, quaternion_manifold, x);

  const ceres::Solver::Options options = solver_options(config);
  solve_stages(problem, options, loop_kernel_scales(problem, robust_blocks, config), config, loop_loss, result);
  read_back(x, plane_nodes, poses, result);
}

}  // namespace detail
}  // namespace loopd
