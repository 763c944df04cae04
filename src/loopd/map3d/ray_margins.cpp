#include "loopd/map3d/ray_margins.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "loopd/base/kdtree.hpp"

namespace loopd {

std::vector<float> ray_stop_margins(const PointCloud& cloud_sensor, double resolution, const RayMarginConfig& config) {
  const auto n = static_cast<std::ptrdiff_t>(cloud_sensor.size());
  const float head_on = static_cast<float>(resolution * (1.0 + config.gain));
  std::vector<float> margin(cloud_sensor.size(), head_on);
  if (n < config.neighbours) return margin;
  const KdTree3f tree(cloud_sensor.points);
  const int k = config.neighbours;
#pragma omp parallel
  {
    std::vector<int> idx(static_cast<std::size_t>(k));
    std::vector<float> d2(static_cast<std::size_t>(k));
#pragma omp for schedule(static)
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      const Eigen::Vector3f& p = cloud_sensor.points[static_cast<std::size_t>(i)];
      const int found = tree.knn(p, k, idx.data(), d2.data());
      if (found < 3 || !(p.norm() > 0.0f)) continue;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (int j = 0; j < found; ++j) mean += cloud_sensor.points[static_cast<std::size_t>(idx[static_cast<std::size_t>(j)])].cast<double>();
      mean /= found;
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (int j = 0; j < found; ++j) {
        const Eigen::Vector3d q = cloud_sensor.points[static_cast<std::size_t>(idx[static_cast<std::size_t>(j)])].cast<double>() - mean;
        cov += q * q.transpose();
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
      const Eigen::Vector3d normal = eig.eigenvectors().col(0);  // smallest eigenvalue
      const double c = std::abs(normal.dot(p.cast<double>().normalized()));
      margin[static_cast<std::size_t>(i)] = static_cast<float>(resolution * (1.0 + config.gain / std::max(c, config.min_cosine)));
    }
  }
  return margin;
}

}  // namespace loopd
