#pragma once
// Private to loopd_descriptor: the steps both M2DP backends share (frame from moments, plane table,
// bin edges, singular vectors), so that the CPU reference and the OpenCL host differ only in where
// the reductions and the binning run.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "loopd/descriptor/m2dp.hpp"

namespace loopd::detail {

/// First-pass result: centroid and covariance (any shift already removed from the centroid by the caller).
struct FirstMoments {
  double count = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< in the coordinates the caller binned in
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

/// Second-pass sums about the first-pass centroid: extent, third moments along the sign axes, and centred first and
/// second moments in the first-pass PCA axes (accurate even when the first pass was summed in float).
struct SecondMoments {
  double max_r2 = 0;                                 ///< [m^2] farthest point from the centroid, squared
  Eigen::Vector3d third = Eigen::Vector3d::Zero();   ///< sum of (b_k . q)^3 per sign axis b_k
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();  ///< sum of (a_j . q)(a_k . q) in the PCA axes a
  Eigen::Vector3d first = Eigen::Vector3d::Zero();   ///< sum of a_k . q
};

/// Principal axes (rows, descending variance) of a covariance.
Eigen::Matrix3d pca_axes(const Eigen::Matrix3d& covariance);

/// Axes (rows) of the frame before the sign rule: PCA of the covariance (kPca), or z up and the principal axes of the
/// ground-plane (x, y) covariance (kGravityAligned). These are also the sign axes of the second pass.
Eigen::Matrix3d frame_axes(const Eigen::Matrix3d& covariance, M2dpFrame frame);

/// Checks the first pass; empty when fine, else the error text (too few points, non-finite coordinates).
std::string check_first(const FirstMoments& m);

/// The final frame of a scan.
struct Frame {
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  ///< rows x, y, z in the binning coordinates
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double max_r2 = 0;
  std::string error;  ///< non-empty: degenerate (all points equal, collinear, non-finite)
};

/// Refines centroid and covariance with the second pass, checks degeneracy, and fixes the axis signs by the third
/// moment rule: x flipped so that its third moment is >= 0, for kPca z likewise, y = z cross x (right-handed);
/// for kGravityAligned z stays (0, 0, 1).
Frame finish_frame(const FirstMoments& first, const Eigen::Matrix3d& pca, const Eigen::Matrix3d& sign_axes, const SecondMoments& s, M2dpFrame frame);

/// Plane table: M2DP_PLANE_STRIDE floats per plane (e1, -c.e1, e2, -c.e2), in the binning coordinates.
/// Plane (i, j), row i * q + j: azimuth theta_i = -pi/2 + i pi/p, elevation phi_j = j pi/(2q),
/// normal n = (cos phi cos theta, cos phi sin theta, sin phi) in the frame (He 2016; Vlaminck 2019 Sec. 4.1).
std::vector<float> plane_table(const M2dpConfig& config, const Eigen::Matrix3d& axes, const Eigen::Vector3d& centroid);

/// Bin parameters: squared ring edges (k^2 r)^2, k = 1..l-1 with l^2 r = max radius (Vlaminck 2019 Sec. 4.1);
/// then tan(j 2 pi / t), j = 1..t/4-1: the sector boundaries inside one quarter turn (t is a multiple of 4).
std::vector<float> bin_params(const M2dpConfig& config, double max_r2);

/// Bin of one projected point (ring * t + sector), by comparisons only (no sqrt, no atan2); the same arithmetic
/// as the vectorised CPU loops (m2dp_cpu.cpp) and kernels/m2dp.cl.
/// Sector s = floor(angle(-u, -v) / (2 pi / t)), i.e. angles over (-pi, pi] counted from -pi: the half turn from
/// the sign of v, the quarter from the sign of the folded u, and inside the quarter the count of boundaries
/// tan(j 2 pi / t) <= |v| / |u|, mirrored in the second quarter.
inline int bin_of(float u, float v, const float* params, int l, int t) {
  const float r2 = u * u + v * v;
  int ring = 0;
  for (int k = 0; k < l - 1; ++k) ring += (r2 >= params[k]) ? 1 : 0;
  const bool lower = v < 0.0f;
  const float a = u < 0.0f ? -u : u, b = lower ? -v : v;
  const bool mirrored = lower ? (u > 0.0f) : (u < 0.0f);
  int k = 0;
  const float* tq = params + (l - 1);
  for (int j = 0; j < t / 4 - 1; ++j) k += (b >= a * tq[j]) ? 1 : 0;
  const int sector = (lower ? 0 : t / 2) + (mirrored ? t / 2 - 1 - k : k);
  return ring * t + sector;
}

/// First left and right singular vectors of the signature matrix A (rows = planes, row-major), by power
/// iteration on A^T A from a positive start (A >= 0, so both vectors come out non-negative: the canonical sign).
/// Fills result->descriptor (u then v) and ok; error when A is all zero.
void descriptor_from_signature(const std::vector<std::uint32_t>& signature, const M2dpConfig& config, M2dpResult* result);

/// Stride of the points that are binned: every ceil(N / max_points)-th point when N > max_points > 0, else 1.
int binning_stride(std::size_t num_points, int max_points);

/// Points after the max_points stride rule (a copy only when subsampling).
const std::vector<Eigen::Vector3f>& subsample(const std::vector<Eigen::Vector3f>& points, int max_points, std::vector<Eigen::Vector3f>* storage);

/// CPU reference backend.
M2dpResult compute_m2dp_cpu(const std::vector<Eigen::Vector3f>& points, const M2dpConfig& config);

/// OpenCL backend (m2dp_opencl.cpp). Construction fails softly: check error() afterwards.
class M2dpOpenCl {
 public:
  explicit M2dpOpenCl(const M2dpConfig& config);
  ~M2dpOpenCl();
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  const std::string& device_name() const { return device_name_; }
  M2dpResult compute(const std::vector<Eigen::Vector3f>& points);

 private:
  struct State;
  M2dpConfig config_;
  std::string error_;
  std::string device_name_;
  std::unique_ptr<State> state_;
};

}  // namespace loopd::detail
