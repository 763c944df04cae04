#include "loopd/correction/pose_graph.hpp"

#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>

#include "loopd/core/stopwatch.hpp"

namespace loopd {

std::optional<std::string> PoseGraphConfig::validate() const {
  if (!(odometry_translation_sigma > 0.0) || !(odometry_rotation_sigma > 0.0)) return "odometry sigmas must be > 0";
  if (!(loop_translation_sigma > 0.0) || !(loop_rotation_sigma > 0.0)) return "loop sigmas must be > 0";
  if (!(max_loop_information > 0.0) || !(min_loop_information > 0.0) || min_loop_information > max_loop_information)
    return "need 0 < min_loop_information <= max_loop_information";
  if (!(loop_loss_scale > 0.0)) return "loop_loss_scale must be > 0";
  if (!(graduated_start_factor >= 1.0)) return "graduated_start_factor must be >= 1";
  if (!(plane_normal_sigma > 0.0) || !(plane_distance_sigma > 0.0)) return "plane sigmas must be > 0";
  if (chain_stride < 0) return "chain_stride must be >= 0";
  if (loop_end_stride < 1) return "loop_end_stride must be >= 1";
  if (max_iterations < 1) return "max_iterations must be >= 1";
  if (num_threads < 1) return "num_threads must be >= 1";
  if (auto err = weights.validate()) return "weights: " + *err;
  return std::nullopt;
}

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

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

Matrix6d diagonal_sqrt_info(double sigma_t, double sigma_r) {
  Vector6d d;
  d << Eigen::Vector3d::Constant(1.0 / sigma_t), Eigen::Vector3d::Constant(1.0 / sigma_r);
  return d.asDiagonal();
}

/// Loop information -> square root, with the GICP Hessian's scale capped (see PoseGraphConfig).
Matrix6d loop_sqrt_info(const Matrix6d& information, const PoseGraphConfig& config) {
  if (information.isZero(0.0) || !information.allFinite())
    return diagonal_sqrt_info(config.loop_translation_sigma, config.loop_rotation_sigma);
  const Matrix6d sym = 0.5 * (information + information.transpose());
  Eigen::SelfAdjointEigenSolver<Matrix6d> es(sym);
  Vector6d lambda = es.eigenvalues();
  const double max_l = lambda.maxCoeff();
  if (!(max_l > 0.0)) return diagonal_sqrt_info(config.loop_translation_sigma, config.loop_rotation_sigma);
  if (max_l > config.max_loop_information) lambda *= config.max_loop_information / max_l;
  for (int k = 0; k < 6; ++k) lambda[k] = std::max(lambda[k], config.min_loop_information);
  return lambda.cwiseSqrt().asDiagonal() * es.eigenvectors().transpose();
}

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

/// One edge of the graph being solved (node indices of that graph).
struct Edge {
  int a = 0, b = 0;
  Eigen::Isometry3d Z = Eigen::Isometry3d::Identity();
  Matrix6d sqrt_info = Matrix6d::Identity();
  bool robust = false;
};

/// Adjoint of T for right perturbations in (t, r) order: T exp(xi) = exp(Ad(T) xi) T.
Matrix6d adjoint(const Eigen::Isometry3d& T) {
  Matrix6d A = Matrix6d::Zero();
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  A.topLeftCorner<3, 3>() = R;
  A.topRightCorner<3, 3>() = tx * R;
  A.bottomRightCorner<3, 3>() = R;
  return A;
}

Matrix6d sqrt_of_information(const Matrix6d& information) {
  Eigen::LLT<Matrix6d> llt(0.5 * (information + information.transpose()));
  if (llt.info() == Eigen::Success) return llt.matrixU();
  Eigen::SelfAdjointEigenSolver<Matrix6d> es(0.5 * (information + information.transpose()));
  return es.eigenvalues().cwiseMax(1e-12).cwiseSqrt().asDiagonal() * es.eigenvectors().transpose();
}

/// @brief Whether `index` (a keyframe position) names one of `n` poses.
bool in_range(std::int64_t index, std::size_t n) { return index >= 0 && index < static_cast<std::int64_t>(n); }

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
std::vector<ceres::ResidualBlockId> add_edge_residuals(ceres::Problem& problem, const std::vector<Edge>& edges, const PoseGraphConfig& config,
                                                       ceres::LossFunctionWrapper& loop_loss, NodeParameters& x) {
  std::vector<ceres::ResidualBlockId> robust_blocks;
  for (const Edge& e : edges) {
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
    nodes.storage.insert(nodes.storage.end(), {n_w.x(), n_w.y(), n_w.z(), o.plane_sensor[3] / o.plane_sensor.head<3>().norm() - n_w.dot(T.translation())});
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
    problem.AddResidualBlock(PlaneError::create(obs, config.plane_normal_sigma, config.plane_distance_sigma), nullptr, &x.p[3 * i],
                             &x.q[4 * i], &nodes.storage[4 * s], &nodes.storage[4 * s + 3]);
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

/// @brief Solves a graph over `poses` (node 0 fixed) in place.
void solve_graph(std::vector<Eigen::Isometry3d>& poses, const std::vector<Edge>& edges, const std::vector<PlaneObservation>& planes,
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

/// @brief Odometry edge covariances: variance proportional to the heuristic's share c_ij / mean(c) (Vlaminck 2019,
/// Sec. 4.4), or the given information.
class OdometryCovariance {
 public:
  OdometryCovariance(const std::vector<Eigen::Isometry3d>& odometry_poses, const std::vector<double>& residuals,
                     const std::vector<Eigen::Matrix<double, 6, 6>>& odometry_information, const PoseGraphConfig& config)
      : c_(edge_weights(odometry_poses, residuals, config.weights)), information_(odometry_information), config_(config) {
    const std::size_t n = odometry_poses.size();
    for (std::size_t i = 1; i < n; ++i) mean_c_ += c_[i];
    mean_c_ /= static_cast<double>(n - 1);
    if (!(mean_c_ > 0.0)) mean_c_ = 1.0;
    have_cov_ = odometry_information.size() == n;
  }

  /// @brief Covariance of the odometry step (i-1, i), (t, r) order.
  Matrix6d operator()(std::size_t i) const {
    if (have_cov_ && information_[i].allFinite() && !information_[i].isZero(0.0)) {
      Eigen::LDLT<Matrix6d> ldlt(0.5 * (information_[i] + information_[i].transpose()));
      if (ldlt.info() == Eigen::Success) return ldlt.solve(Matrix6d::Identity());
    }
    const double f = std::max(c_[i] / mean_c_, 1e-6);
    Vector6d v;
    v << Eigen::Vector3d::Constant(f * config_.odometry_translation_sigma * config_.odometry_translation_sigma),
        Eigen::Vector3d::Constant(f * config_.odometry_rotation_sigma * config_.odometry_rotation_sigma);
    return v.asDiagonal();
  }

  const std::vector<double>& weights() const { return c_; }  ///< c_i of the step (i-1, i)
  bool have_information() const { return have_cov_; }        ///< every step's information was given

 private:
  std::vector<double> c_;
  double mean_c_ = 0.0;
  bool have_cov_ = false;
  const std::vector<Eigen::Matrix<double, 6, 6>>& information_;
  const PoseGraphConfig& config_;
};

/// @brief Loops whose ends are two different poses among the n (zero-length loops and bad indices carry no information).
std::vector<const LoopConstraint*> valid_loops(const std::vector<LoopConstraint>& loops, std::size_t n) {
  std::vector<const LoopConstraint*> valid;
  for (const LoopConstraint& l : loops)
    if (in_range(l.query_index, n) && in_range(l.match_index, n) && l.query_index != l.match_index) valid.push_back(&l);
  return valid;
}

/// @brief The keyframes solved as nodes and, for every keyframe, its nearest node.
struct NodeLayout {
  std::vector<int> anchors;       ///< keyframe of each node, increasing
  std::vector<int> nearest_node;  ///< per keyframe: its nearest node (itself when it is one)
  bool reduce = false;            ///< false: every keyframe is a node
};

/// @brief Anchors: keyframes that carry more than odometry (first pose, every chain_stride-th, loop ends, plane
/// observations), sorted and unique.
std::vector<int> carrying_keyframes(std::size_t n, const std::vector<const LoopConstraint*>& loops, const std::vector<PlaneObservation>& planes,
                                    const PoseGraphConfig& config) {
  std::vector<int> anchors{0};
  if (config.chain_stride > 0)
    for (std::size_t i = static_cast<std::size_t>(config.chain_stride); i < n; i += static_cast<std::size_t>(config.chain_stride))
      anchors.push_back(static_cast<int>(i));
  for (const LoopConstraint* l : loops) {
    anchors.push_back(static_cast<int>(l->query_index));
    anchors.push_back(static_cast<int>(l->match_index));
  }
  if (config.use_plane_constraints)
    for (const PlaneObservation& o : planes)
      if (in_range(o.index, n)) anchors.push_back(static_cast<int>(o.index));
  std::sort(anchors.begin(), anchors.end());
  anchors.erase(std::unique(anchors.begin(), anchors.end()), anchors.end());
  return anchors;
}

/// @brief Nearest node of every keyframe (itself when it is one; the earlier node on a tie).
std::vector<int> nearest_nodes(const std::vector<int>& anchors, std::size_t n) {
  std::vector<int> nearest_node(n, 0);
  for (std::size_t k = 0; k < anchors.size(); ++k) {
    const auto a = static_cast<std::size_t>(anchors[k]);
    const std::size_t b = k + 1 < anchors.size() ? static_cast<std::size_t>(anchors[k + 1]) : n;
    for (std::size_t i = a; i < b; ++i) nearest_node[i] = (k + 1 < anchors.size() && i - a > b - i) ? static_cast<int>(k + 1) : static_cast<int>(k);
  }
  return nearest_node;
}

/// @brief Chooses the nodes: the carrying keyframes when they are few (reduce_chains), every loop_end_stride-th
/// keyframe when loop ends are dense, else every keyframe.
NodeLayout choose_nodes(std::size_t n, const std::vector<const LoopConstraint*>& loops, const std::vector<PlaneObservation>& planes,
                        const PoseGraphConfig& config) {
  NodeLayout layout;
  std::vector<int>& anchors = layout.anchors;
  anchors = carrying_keyframes(n, loops, planes, config);
  bool reduce = config.reduce_chains && anchors.size() * 2 < n;
  // Dense loop ends: every loop_end_stride-th keyframe (and the last) is a node; loop ends and plane observations
  // are moved to their nearest node below.
  const bool decimate = config.reduce_chains && !reduce && config.loop_end_stride > 1 && n > 2 * static_cast<std::size_t>(config.loop_end_stride);
  if (decimate) {
    anchors.clear();
    for (std::size_t i = 0; i < n; i += static_cast<std::size_t>(config.loop_end_stride)) anchors.push_back(static_cast<int>(i));
    if (anchors.back() != static_cast<int>(n) - 1) anchors.push_back(static_cast<int>(n) - 1);
    reduce = true;
  } else if (!reduce) {
    anchors.resize(n);
    for (std::size_t i = 0; i < n; ++i) anchors[i] = static_cast<int>(i);
  }
  layout.reduce = reduce;
  layout.nearest_node = nearest_nodes(anchors, n);
  return layout;
}

/// @brief Odometry from keyframe i to its node (identity for a node).
Eigen::Isometry3d to_node(const std::vector<Eigen::Isometry3d>& odometry_poses, const NodeLayout& layout, std::size_t i) {
  return odometry_poses[i].inverse() *
         odometry_poses[static_cast<std::size_t>(layout.anchors[static_cast<std::size_t>(layout.nearest_node[i])])];
}

/// @brief Odometry chain between consecutive anchors a < b, composed: Z_ab = Z_{a+1} ... Z_b; its covariance propagated
/// with adjoints (a right perturbation of step i appears at b as Ad(T_{i,b}^-1) xi_i).
void add_odometry_chain_edges(const std::vector<Eigen::Isometry3d>& odometry_poses, const std::vector<int>& anchors,
                              const OdometryCovariance& odometry_covariance, std::vector<Edge>& edges) {
  for (std::size_t k = 0; k + 1 < anchors.size(); ++k) {
    const int a = anchors[k], b = anchors[k + 1];
    Edge e;
    e.a = static_cast<int>(k);
    e.b = static_cast<int>(k + 1);
    e.Z = odometry_poses[static_cast<std::size_t>(a)].inverse() * odometry_poses[static_cast<std::size_t>(b)];
    if (b == a + 1) {
      e.sqrt_info = sqrt_of_information(odometry_covariance(static_cast<std::size_t>(b)).inverse());
    } else {
      Matrix6d cov = Matrix6d::Zero();
      const Eigen::Isometry3d T_b_inv = odometry_poses[static_cast<std::size_t>(b)].inverse();
      for (int i = a + 1; i <= b; ++i) {
        const Matrix6d A = adjoint(T_b_inv * odometry_poses[static_cast<std::size_t>(i)]);  // T_{i,b}^-1 = T_b^-1 T_i
        cov += A * odometry_covariance(static_cast<std::size_t>(i)) * A.transpose();
      }
      e.sqrt_info = sqrt_of_information(cov.inverse());
    }
    edges.push_back(e);
  }
}

/// @brief One robust edge per loop between the nodes of its ends (none when both ends share a node).
void add_loop_edges(const std::vector<const LoopConstraint*>& loops, const std::vector<Eigen::Isometry3d>& odometry_poses,
                    const NodeLayout& layout, const PoseGraphConfig& config, std::vector<Edge>& edges) {
  for (const LoopConstraint* l : loops) {
    const auto m = static_cast<std::size_t>(l->match_index), q = static_cast<std::size_t>(l->query_index);
    Edge e;
    e.a = layout.nearest_node[m];
    e.b = layout.nearest_node[q];
    if (e.a == e.b) continue;  // both ends on one node (a loop over fewer than loop_end_stride keyframes)
    // Z between the nodes: node_m <- m by odometry, m <- q by the loop, q <- node_q by odometry (a few steps, taken
    // as exact next to the loop's own uncertainty).
    e.Z = to_node(odometry_poses, layout, m).inverse() * l->T_match_query * to_node(odometry_poses, layout, q);
    e.sqrt_info = loop_sqrt_info(l->information, config);
    e.robust = true;
    edges.push_back(e);
  }
}

/// @brief The plane observations moved to the nearest node of their keyframe (index = node index).
std::vector<PlaneObservation> planes_on_nodes(const std::vector<PlaneObservation>& planes, const std::vector<Eigen::Isometry3d>& odometry_poses,
                                              const NodeLayout& layout) {
  std::vector<PlaneObservation> node_planes;
  for (const PlaneObservation& o : planes)
    if (in_range(o.index, odometry_poses.size())) {
      PlaneObservation m = o;
      const auto i = static_cast<std::size_t>(o.index);
      m.index = layout.nearest_node[i];
      if (static_cast<std::size_t>(layout.anchors[static_cast<std::size_t>(m.index)]) != i) {
        // The plane seen from keyframe i, expressed in its node's frame: n' = R^T n, d' = d + n . t for T = T_i_node.
        const Eigen::Isometry3d T = to_node(odometry_poses, layout, i);
        const Eigen::Vector3d nrm = o.plane_sensor.head<3>();
        m.plane_sensor.head<3>() = T.linear().transpose() * nrm;
        m.plane_sensor.w() = o.plane_sensor.w() + nrm.dot(T.translation());
      }
      node_planes.push_back(m);
    }
  return node_planes;
}

/// @brief Fill each chain between two solved anchors: odometry attached rigidly at a, then the end mismatch at b spread
/// with the same shares as the heuristic (Vlaminck 2019, Eq. 3) -- the least-squares answer for a chain with
/// fixed ends when its variance is proportional to c_ij. After the last anchor the chain moves rigidly.
void fill_chains(const std::vector<Eigen::Isometry3d>& odometry_poses, const std::vector<int>& anchors, const std::vector<Eigen::Isometry3d>& nodes,
                 const OdometryCovariance& odometry_covariance, const PoseGraphConfig& config, std::vector<Eigen::Isometry3d>& out) {
  const std::size_t n = odometry_poses.size();
  const std::vector<double>& c = odometry_covariance.weights();
  out = odometry_poses;
  for (std::size_t k = 0; k < anchors.size(); ++k) {
    const auto a = static_cast<std::size_t>(anchors[k]);
    const std::size_t b = k + 1 < anchors.size() ? static_cast<std::size_t>(anchors[k + 1]) : n - 1;
    const Eigen::Isometry3d T = nodes[k] * odometry_poses[a].inverse();
    for (std::size_t i = a; i <= b; ++i) out[i] = T * odometry_poses[i];
    if (k + 1 < anchors.size() && b > a + 1) {
      std::vector<Eigen::Isometry3d> chain(out.begin() + static_cast<std::ptrdiff_t>(a), out.begin() + static_cast<std::ptrdiff_t>(b) + 1);
      std::vector<double> w(c.begin() + static_cast<std::ptrdiff_t>(a), c.begin() + static_cast<std::ptrdiff_t>(b) + 1);
      if (odometry_covariance.have_information())  // given step covariances: share by their trace
        for (std::size_t i = a + 1; i <= b; ++i) w[i - a] = odometry_covariance(i).trace();
      LoopConstraint span;
      span.match_index = 0;
      span.query_index = static_cast<decltype(span.query_index)>(b - a);
      span.T_match_query = nodes[k].inverse() * nodes[k + 1];
      apply_heuristic_correction(chain, w, span, config.weights.rotate_positions);
      std::copy(chain.begin(), chain.end(), out.begin() + static_cast<std::ptrdiff_t>(a));
    } else if (k + 1 < anchors.size()) {
      out[b] = nodes[k + 1];
    }
  }
}

}  // namespace

PoseGraphResult optimize_pose_graph(const std::vector<Eigen::Isometry3d>& odometry_poses, const std::vector<double>& residuals,
                                    const std::vector<LoopConstraint>& loops, const std::vector<Eigen::Isometry3d>& initial_guess,
                                    const PoseGraphConfig& config, const std::vector<PlaneObservation>& planes,
                                    const std::vector<Eigen::Matrix<double, 6, 6>>& odometry_information) {
  Stopwatch watch;
  PoseGraphResult result;
  const std::size_t n = odometry_poses.size();
  const std::vector<Eigen::Isometry3d>& init = initial_guess.size() == n ? initial_guess : odometry_poses;
  result.poses = init;
  if (auto err = config.validate()) {
    result.message = "invalid config: " + *err;
    return result;
  }
  if (n < 2) {
    result.converged = true;
    result.message = "fewer than 2 poses";
    return result;
  }

  const OdometryCovariance odometry_covariance(odometry_poses, residuals, odometry_information, config);
  const std::vector<const LoopConstraint*> loops_in_range = valid_loops(loops, n);
  const NodeLayout layout = choose_nodes(n, loops_in_range, planes, config);

  std::vector<Edge> edges;
  add_odometry_chain_edges(odometry_poses, layout.anchors, odometry_covariance, edges);
  add_loop_edges(loops_in_range, odometry_poses, layout, config, edges);
  const std::vector<PlaneObservation> node_planes = planes_on_nodes(planes, odometry_poses, layout);

  std::vector<Eigen::Isometry3d> nodes;
  nodes.reserve(layout.anchors.size());
  for (int a : layout.anchors) nodes.push_back(init[static_cast<std::size_t>(a)]);
  solve_graph(nodes, edges, node_planes, config, result);

  if (!layout.reduce)
    result.poses = nodes;
  else
    fill_chains(odometry_poses, layout.anchors, nodes, odometry_covariance, config, result.poses);
  result.ms = watch.ms();
  return result;
}

}  // namespace loopd
