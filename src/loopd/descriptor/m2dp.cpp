// M2DP dispatch and the steps both backends share (He et al. 2016; Vlaminck et al. 2019, Sec. 4.1).
#include "loopd/descriptor/m2dp.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <iostream>
#include <limits>
#include <stdexcept>

#include "../../../kernels/m2dp_shared.h"
#include "loopd/descriptor/m2dp_internal.hpp"
#include "loopd/base/angles.hpp"

namespace loopd {

namespace {
/// Points closer than this to the centroid everywhere count as one point [m^2].
constexpr double kMinExtent2 = 1e-10;
/// Second principal value below this fraction of the first: collinear.
constexpr double kMinEigenRatio = 1e-8;
}  // namespace

std::string to_string(Backend backend) {
  switch (backend) {
    case Backend::kCpu:
      return "cpu";
    case Backend::kOpenCl:
      return "opencl";
    case Backend::kAuto:
      return "auto";
  }
  return "?";
}
std::string to_string(M2dpFrame frame) { return frame == M2dpFrame::kPca ? "pca" : "gravity"; }
std::optional<Backend> backend_from_string(const std::string& name) {
  if (name == "cpu") return Backend::kCpu;
  if (name == "opencl") return Backend::kOpenCl;
  if (name == "auto") return Backend::kAuto;
  return std::nullopt;
}
std::optional<M2dpFrame> frame_from_string(const std::string& name) {
  if (name == "pca") return M2dpFrame::kPca;
  if (name == "gravity" || name == "gravity_aligned") return M2dpFrame::kGravityAligned;
  return std::nullopt;
}

std::optional<std::string> M2dpConfig::validate() const {
  if (num_rings_l < 1 || num_rings_l > M2DP_MAX_RINGS) return "num_rings_l must be in [1, " + std::to_string(M2DP_MAX_RINGS) + "]";
  if (num_sectors_t < 4 || num_sectors_t > M2DP_MAX_SECTORS || num_sectors_t % 4 != 0)
    return "num_sectors_t must be a multiple of 4 in [4, " + std::to_string(M2DP_MAX_SECTORS) + "]";
  if (num_bins() > M2DP_MAX_BINS) return "num_rings_l * num_sectors_t must be <= " + std::to_string(M2DP_MAX_BINS);
  if (num_azimuths_p < 1 || num_elevations_q < 1) return "num_azimuths_p and num_elevations_q must be >= 1";
  if (num_planes() > 4096) return "num_azimuths_p * num_elevations_q must be <= 4096";
  if (max_points < 0) return "max_points must be >= 0 (0 = all points)";
  if (num_threads < 0) return "num_threads must be >= 0";
  return std::nullopt;
}

namespace detail {

std::string check_first(const FirstMoments& m) {
  if (m.count < 3) return "M2DP needs at least 3 points (got " + std::to_string(static_cast<long long>(m.count)) + ")";
  if (!m.centroid.allFinite() || !m.covariance.allFinite()) return "point cloud has non-finite (NaN/Inf) or overflowing coordinates";
  return {};
}

Eigen::Matrix3d pca_axes(const Eigen::Matrix3d& covariance) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(covariance);
  const Eigen::Matrix3d V = es.eigenvectors();  // ascending eigenvalues
  Eigen::Matrix3d axes;
  axes.row(0) = V.col(2).transpose();
  axes.row(1) = V.col(1).transpose();
  axes.row(2) = V.col(0).transpose();
  return axes;
}

Eigen::Matrix3d frame_axes(const Eigen::Matrix3d& covariance, M2dpFrame frame) {
  // Vlaminck 2019 Sec. 4.1: the two dominant PCA directions become x and y.
  if (frame == M2dpFrame::kPca) return pca_axes(covariance);
  // z stays the sensor's up axis; x and y are the principal axes of the ground-plane (x, y) covariance.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(covariance.topLeftCorner<2, 2>());
  const Eigen::Vector2d d = es.eigenvectors().col(1);
  Eigen::Matrix3d axes;
  axes.row(0) << d.x(), d.y(), 0.0;
  axes.row(1) << -d.y(), d.x(), 0.0;
  axes.row(2) << 0.0, 0.0, 1.0;
  return axes;
}

Frame finish_frame(const FirstMoments& first, const Eigen::Matrix3d& pca, const Eigen::Matrix3d& sign_axes, const SecondMoments& s, M2dpFrame frame) {
  Frame out;
  if (!std::isfinite(s.max_r2) || !s.second.allFinite() || !s.third.allFinite() || !s.first.allFinite()) {
    out.error = "non-finite moments (NaN/Inf coordinates)";
    return out;
  }
  if (s.max_r2 <= kMinExtent2) {
    out.error = "all points coincide (no extent)";
    return out;
  }
  const Eigen::Vector3d delta = s.first / first.count;  // centroid correction, PCA coordinates
  const Eigen::Matrix3d S = s.second / first.count - delta * delta.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(S, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d ev = es.eigenvalues();  // ascending
  if (!(ev(2) > 0) || ev(1) <= kMinEigenRatio * ev(2)) {
    out.error = "points are collinear (no second principal direction)";
    return out;
  }
  out.centroid = first.centroid + pca.transpose() * delta;
  out.max_r2 = s.max_r2;
  const Eigen::Matrix3d covariance = pca.transpose() * S * pca;
  const Eigen::Matrix3d axes = frame_axes(covariance, frame);
  // Third moments were summed along the (unrefined) sign axes; carry their sign over to the refined axes.
  Eigen::Vector3d x = axes.row(0).transpose(), z = axes.row(2).transpose();
  if (s.third(0) * x.dot(sign_axes.row(0).transpose()) < 0) x = -x;
  if (frame == M2dpFrame::kPca && s.third(2) * z.dot(sign_axes.row(2).transpose()) < 0) z = -z;
  if (frame == M2dpFrame::kGravityAligned) z = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d y = z.cross(x);
  out.axes.row(0) = x.transpose();
  out.axes.row(1) = y.transpose();
  out.axes.row(2) = z.transpose();
  return out;
}

std::vector<float> plane_table(const M2dpConfig& config, const Eigen::Matrix3d& axes, const Eigen::Vector3d& centroid) {
  const int p = config.num_azimuths_p, q = config.num_elevations_q;
  std::vector<float> table(static_cast<std::size_t>(p * q) * M2DP_PLANE_STRIDE);
  for (int i = 0; i < p; ++i) {
    const double theta = -kPi / 2 + i * kPi / p;  // azimuth, stride pi/p
    for (int j = 0; j < q; ++j) {
      const double phi = j * kPi / (2.0 * q);  // elevation, stride pi/(2q)
      const Eigen::Vector3d n(std::cos(phi) * std::cos(theta), std::cos(phi) * std::sin(theta), std::sin(phi));
      // In-plane x axis: the frame x axis projected onto the plane (He 2016), normalised; the frame y axis
      // when the normal is x itself (the original code's projection vanishes there).
      Eigen::Vector3d e1 = Eigen::Vector3d::UnitX() - n.x() * n;
      if (e1.norm() < 1e-6) e1 = Eigen::Vector3d::UnitY() - n.y() * n;
      e1.normalize();
      const Eigen::Vector3d e2 = n.cross(e1);
      // Back to the input frame: frame coordinates are axes * (p - c).
      const Eigen::Vector3d E1 = axes.transpose() * e1, E2 = axes.transpose() * e2;
      float* row = table.data() + static_cast<std::size_t>(i * q + j) * M2DP_PLANE_STRIDE;
      row[0] = static_cast<float>(E1.x());
      row[1] = static_cast<float>(E1.y());
      row[2] = static_cast<float>(E1.z());
      row[3] = static_cast<float>(-E1.dot(centroid));
      row[4] = static_cast<float>(E2.x());
      row[5] = static_cast<float>(E2.y());
      row[6] = static_cast<float>(E2.z());
      row[7] = static_cast<float>(-E2.dot(centroid));
    }
  }
  return table;
}

std::vector<float> bin_params(const M2dpConfig& config, double max_r2) {
  const int l = config.num_rings_l, t = config.num_sectors_t;
  std::vector<float> params;
  // Vlaminck 2019 Sec. 4.1: ring radii r, 2^2 r, ..., l^2 r with l^2 r = distance to the farthest point.
  const double r = std::sqrt(max_r2) / (static_cast<double>(l) * l);
  for (int k = 1; k < l; ++k) {
    const double edge = static_cast<double>(k) * k * r;
    params.push_back(static_cast<float>(edge * edge));
  }
  for (int j = 1; j < t / 4; ++j) params.push_back(static_cast<float>(std::tan(j * 2.0 * kPi / t)));
  return params;
}

void descriptor_from_signature(const std::vector<std::uint32_t>& signature, const M2dpConfig& config, M2dpResult* result) {
  const int rows = config.num_planes(), cols = config.num_bins();
  Eigen::MatrixXd A(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      A(r, c) = static_cast<double>(signature[static_cast<std::size_t>(r) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(c)]);
  if (A.sum() <= 0) {
    result->ok = false;
    result->error = "empty signature matrix";
    return;
  }
  // First singular pair from the dominant eigenvector of the smaller Gram matrix (64 x 64 for p*q = 64 planes):
  // one symmetric eigensolve (~0.3 ms), no full SVD of A. The previous power iteration on A^T A needed thousands of
  // 128 x 128 products (tens of ms) when the first two singular values were close.
  // The Gram matrix is summed with lazyProduct: Eigen's GEMM would start OpenMP threads for this small product, and
  // their spin-waits cost more than the product on a busy machine (measured: over half of a 30k-point descriptor).
  Eigen::VectorXd u, v;
  if (rows <= cols) {
    const Eigen::MatrixXd G = A.lazyProduct(A.transpose());
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(G);
    u = es.eigenvectors().col(rows - 1);
    v = A.transpose() * u;
    v.normalize();
  } else {
    const Eigen::MatrixXd G = A.transpose().lazyProduct(A);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(G);
    v = es.eigenvectors().col(cols - 1);
    u = A * v;
    u.normalize();
  }
  // Canonical sign (A >= 0, so the Perron vectors are non-negative): make both sum to a positive value.
  if (v.sum() < 0) v = -v;
  if (u.sum() < 0) u = -u;
  result->descriptor.resize(rows + cols);
  result->descriptor.head(rows) = u.cast<float>();
  result->descriptor.tail(cols) = v.cast<float>();
  result->ok = result->descriptor.allFinite();
  if (!result->ok) {
    result->error = "non-finite descriptor";
    result->descriptor.resize(0);
  }
}

int binning_stride(std::size_t num_points, int max_points) {
  if (max_points <= 0 || num_points <= static_cast<std::size_t>(max_points)) return 1;
  return static_cast<int>((num_points + static_cast<std::size_t>(max_points) - 1) / static_cast<std::size_t>(max_points));
}

const std::vector<Eigen::Vector3f>& subsample(const std::vector<Eigen::Vector3f>& points, int max_points, std::vector<Eigen::Vector3f>* storage) {
  if (max_points <= 0 || points.size() <= static_cast<std::size_t>(max_points)) return points;
  const std::size_t stride = (points.size() + static_cast<std::size_t>(max_points) - 1) / static_cast<std::size_t>(max_points);
  storage->clear();
  storage->reserve(points.size() / stride + 1);
  for (std::size_t i = 0; i < points.size(); i += stride) storage->push_back(points[i]);
  return *storage;
}

}  // namespace detail

M2dp::M2dp(const M2dpConfig& config) : config_(config) {
  if (auto err = config_.validate()) throw std::invalid_argument("M2dpConfig: " + *err);
  backend_ = Backend::kCpu;
  if (config_.backend == Backend::kCpu) return;
#ifdef LOOPD_WITH_OPENCL
  auto cl = std::make_unique<detail::M2dpOpenCl>(config_);
  if (cl->ok()) {
    opencl_ = std::move(cl);
    backend_ = Backend::kOpenCl;
    return;
  }
  const std::string why = cl->error();
#else
  const std::string why = "built without OpenCL (LOOPD_WITH_OPENCL=OFF)";
#endif
  if (config_.backend == Backend::kOpenCl && !config_.log_fallback) throw std::runtime_error("M2DP OpenCL backend unavailable: " + why);
  if (config_.log_fallback) std::cerr << "loopd M2DP: OpenCL unavailable (" << why << "); using the CPU backend\n";
}

M2dp::~M2dp() = default;

std::string M2dp::device_name() const { return opencl_ ? opencl_->device_name() : std::string("cpu"); }

M2dpResult M2dp::compute(const PointCloud& cloud) const { return compute(cloud.points); }

M2dpResult M2dp::compute(const std::vector<Eigen::Vector3f>& points) const {
  // max_points thins only the O(N x planes) binning (detail::binning_stride); the frame and the outer ring radius
  // come from all points, since the farthest point and the axes are what a subsample perturbs most.
  if (opencl_) return opencl_->compute(points);
  return detail::compute_m2dp_cpu(points, config_);
}

float descriptor_distance(const Eigen::VectorXf& a, const Eigen::VectorXf& b) {
  if (a.size() != b.size()) return std::numeric_limits<float>::infinity();
  return (a - b).norm();
}

}  // namespace loopd
