#include "loopd/correction/pose_graph.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_set>

#include "loopd/base/stopwatch.hpp"
#include "loopd/correction/pose_graph_internal.hpp"

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
  if (max_nodes < 0 || max_nodes == 1) return "max_nodes must be 0 (no bound) or >= 2";
  if (max_iterations < 1) return "max_iterations must be >= 1";
  if (num_threads < 1) return "num_threads must be >= 1";
  if (auto err = weights.validate()) return "weights: " + *err;
  return std::nullopt;
}

namespace {

using detail::GraphEdge;
using detail::in_range;
using detail::Matrix6d;
using detail::NodeLayout;
using detail::to_node;
using detail::Vector6d;

Matrix6d diagonal_sqrt_info(double sigma_t, double sigma_r) {
  Vector6d d;
  d << Eigen::Vector3d::Constant(1.0 / sigma_t), Eigen::Vector3d::Constant(1.0 / sigma_r);
  return d.asDiagonal();
}

/// Loop information -> square root, with the GICP Hessian's scale capped (see PoseGraphConfig).
Matrix6d loop_sqrt_info(const Matrix6d& information, const PoseGraphConfig& config) {
  if (information.isZero(0.0) || !information.allFinite()) return diagonal_sqrt_info(config.loop_translation_sigma, config.loop_rotation_sigma);
  const Matrix6d sym = 0.5 * (information + information.transpose());
  Eigen::SelfAdjointEigenSolver<Matrix6d> es(sym);
  Vector6d lambda = es.eigenvalues();
  const double max_l = lambda.maxCoeff();
  if (!(max_l > 0.0)) return diagonal_sqrt_info(config.loop_translation_sigma, config.loop_rotation_sigma);
  if (max_l > config.max_loop_information) lambda *= config.max_loop_information / max_l;
  for (int k = 0; k < 6; ++k) lambda[k] = std::max(lambda[k], config.min_loop_information);
  return lambda.cwiseSqrt().asDiagonal() * es.eigenvectors().transpose();
}

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

/// @brief Odometry chain between consecutive anchors a < b, composed: Z_ab = Z_{a+1} ... Z_b; its covariance propagated
/// with adjoints (a right perturbation of step i appears at b as Ad(T_{i,b}^-1) xi_i).
void add_odometry_chain_edges(const std::vector<Eigen::Isometry3d>& odometry_poses, const std::vector<int>& anchors,
                              const OdometryCovariance& odometry_covariance, std::vector<GraphEdge>& edges) {
  for (std::size_t k = 0; k + 1 < anchors.size(); ++k) {
    const int a = anchors[k], b = anchors[k + 1];
    GraphEdge e;
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

/// @brief One robust edge per loop between the nodes of its ends (none when both ends share a node). In a graph capped
/// by max_nodes only the first loop between two nodes becomes an edge: the others join the same two places a few
/// keyframes apart (20,119 loops on a lap visited 45 times, 4000 nodes: a solve's peak 244 -> 231 MB).
void add_loop_edges(const std::vector<const LoopConstraint*>& loops, const std::vector<Eigen::Isometry3d>& odometry_poses, const NodeLayout& layout,
                    const PoseGraphConfig& config, std::vector<GraphEdge>& edges) {
  std::unordered_set<std::int64_t> joined;  // node pairs (a, b) with an edge, when capped
  for (const LoopConstraint* l : loops) {
    const auto m = static_cast<std::size_t>(l->match_index), q = static_cast<std::size_t>(l->query_index);
    GraphEdge e;
    e.a = layout.nearest_node[m];
    e.b = layout.nearest_node[q];
    if (e.a == e.b) continue;  // both ends on one node (a loop over fewer than loop_end_stride keyframes)
    if (layout.capped && !joined.insert(static_cast<std::int64_t>(std::min(e.a, e.b)) << 32 | std::max(e.a, e.b)).second) continue;
    // Z between the nodes: node_m <- m by odometry, m <- q by the loop, q <- node_q by odometry (a few steps, taken
    // as exact next to the loop's own uncertainty).
    e.Z = to_node(odometry_poses, layout, m).inverse() * l->T_match_query * to_node(odometry_poses, layout, q);
    e.sqrt_info = loop_sqrt_info(l->information, config);
    e.robust = l->robust;
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
                                    const std::vector<Eigen::Matrix<double, 6, 6>>& odometry_information,
                                    const std::vector<PoseIndex>& segment_starts) {
  Stopwatch watch;
  PoseGraphResult result;
  const std::size_t n = odometry_poses.size();
  const auto finite = [](const std::vector<Eigen::Isometry3d>& poses) {
    return std::all_of(poses.begin(), poses.end(), [](const Eigen::Isometry3d& T) { return T.matrix().allFinite(); });
  };
  // Ceres aborts the process (a CHECK, not an error) on a non-finite parameter block: such a start is never handed to it.
  if (!finite(odometry_poses)) {
    result.poses = initial_guess.size() == n ? initial_guess : odometry_poses;
    result.message = "not solved: a chain pose is not finite";
    return result;
  }
  const bool usable_guess = initial_guess.size() == n && finite(initial_guess);
  const std::vector<Eigen::Isometry3d>& init = usable_guess ? initial_guess : odometry_poses;
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
  const std::vector<const LoopConstraint*> loops_in_range = detail::valid_loops(loops, n);
  const NodeLayout layout = detail::choose_nodes(n, loops_in_range, planes, config, segment_starts);

  std::vector<GraphEdge> edges;
  edges.reserve(layout.anchors.size() + loops_in_range.size());  // one allocation, no doubling copies
  add_odometry_chain_edges(odometry_poses, layout.anchors, odometry_covariance, edges);
  add_loop_edges(loops_in_range, odometry_poses, layout, config, edges);
  const std::vector<PlaneObservation> node_planes = planes_on_nodes(planes, odometry_poses, layout);

  std::vector<Eigen::Isometry3d> nodes;
  nodes.reserve(layout.anchors.size());
  for (int a : layout.anchors) nodes.push_back(init[static_cast<std::size_t>(a)]);
  detail::solve_graph(nodes, edges, node_planes, config, result);

  if (!layout.reduce)
    result.poses = nodes;
  else
    fill_chains(odometry_poses, layout.anchors, nodes, odometry_covariance, config, result.poses);
  if (!finite(result.poses)) {  // nothing non-finite leaves the solver: the start stays
    result.poses = init;
    result.converged = false;
    result.message = "the solve gave non-finite poses; kept its start (" + result.message + ")";
  }
  if (initial_guess.size() == n && !usable_guess) result.message += " (the start given was not finite: solved from the chain)";
  result.ms = watch.ms();
  return result;
}

}  // namespace loopd
