// M2DP CPU reference (the oracle for the OpenCL backend): plain loops, double-precision moments,
// the same comparison binning as kernels/m2dp.cl, OpenMP over the projection planes.
#include <omp.h>

#include <algorithm>
#include <cmath>

#include "../../../kernels/m2dp_shared.h"
#include "loopd/descriptor/m2dp_internal.hpp"

namespace loopd::detail {

namespace {

FirstMoments first_moments(const std::vector<Eigen::Vector3f>& points) {
  FirstMoments m;
  m.count = static_cast<double>(points.size());
  if (points.empty()) return m;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : points) sum += p.cast<double>();
  m.centroid = sum / m.count;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) {
    const Eigen::Vector3d q = p.cast<double>() - m.centroid;
    cov.noalias() += q * q.transpose();
  }
  m.covariance = cov / m.count;
  return m;
}

SecondMoments second_moments(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& centroid, const Eigen::Matrix3d& pca,
                             const Eigen::Matrix3d& sign_axes) {
  SecondMoments s;
  for (const auto& p : points) {
    const Eigen::Vector3d q = p.cast<double>() - centroid;
    s.max_r2 = std::max(s.max_r2, q.squaredNorm());
    const Eigen::Vector3d t = pca * q, w = sign_axes * q;
    s.third += w.cwiseProduct(w).cwiseProduct(w);
    s.second.noalias() += t * t.transpose();
    s.first += t;
  }
  return s;
}

}  // namespace

M2dpResult compute_m2dp_cpu(const std::vector<Eigen::Vector3f>& points, const M2dpConfig& config) {
  M2dpResult result;
  result.backend = Backend::kCpu;
  result.num_points = static_cast<int>(points.size());

  // Vlaminck 2019 Sec. 4.1, step 1: centroid; step 2: reference frame.
  const FirstMoments first = first_moments(points);
  if (std::string err = check_first(first); !err.empty()) {
    result.error = err;
    return result;
  }
  const Eigen::Matrix3d pca = pca_axes(first.covariance);
  const Eigen::Matrix3d sign_axes = frame_axes(first.covariance, config.frame);
  const SecondMoments second = second_moments(points, first.centroid, pca, sign_axes);
  const Frame f = finish_frame(first, pca, sign_axes, second, config.frame);
  if (!f.error.empty()) {
    result.error = f.error;
    return result;
  }
  result.axes = f.axes;
  result.centroid = f.centroid;
  result.max_radius = std::sqrt(f.max_r2);

  // Step 3: project onto the p*q planes and count points per (ring, sector) bin: signature matrix A.
  const int l = config.num_rings_l, t = config.num_sectors_t, num_planes = config.num_planes(), num_bins = config.num_bins();
  const std::vector<float> planes = plane_table(config, f.axes, f.centroid);
  const std::vector<float> params = bin_params(config, f.max_r2);
  std::vector<std::uint32_t> signature(static_cast<std::size_t>(num_planes) * num_bins, 0u);
  const int n = static_cast<int>(points.size());
  const int threads = config.num_threads > 0 ? config.num_threads : omp_get_max_threads();

#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (int j = 0; j < num_planes; ++j) {
    const float* pl = planes.data() + static_cast<std::size_t>(j) * M2DP_PLANE_STRIDE;
    std::uint32_t* hist = signature.data() + static_cast<std::size_t>(j) * num_bins;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3f& p = points[i];
      const float u = pl[0] * p.x() + pl[1] * p.y() + pl[2] * p.z() + pl[3];
      const float v = pl[4] * p.x() + pl[5] * p.y() + pl[6] * p.z() + pl[7];
      ++hist[bin_of(u, v, params.data(), l, t)];
    }
  }

  // Step 4: first left and right singular vectors of A.
  descriptor_from_signature(signature, config, &result);
  return result;
}

}  // namespace loopd::detail
