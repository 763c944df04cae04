#include "loopd/base/closest_pose.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace loopd {

std::vector<double> closest_pose_errors(const std::vector<Eigen::Vector3d>& estimate, const std::vector<Eigen::Vector3d>& ground_truth) {
  std::vector<double> out;
  out.reserve(estimate.size());
  if (ground_truth.empty()) return out;
  // Ground truth sorted by x: scan outwards from the insertion point and stop once |dx| exceeds the best distance.
  std::vector<Eigen::Vector3d> gt = ground_truth;
  std::sort(gt.begin(), gt.end(), [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.x() < b.x(); });
  for (const auto& p : estimate) {
    const auto it = std::lower_bound(gt.begin(), gt.end(), p.x(), [](const Eigen::Vector3d& g, double x) { return g.x() < x; });
    double best2 = std::numeric_limits<double>::infinity();
    for (auto f = it; f != gt.end(); ++f) {
      const double dx = f->x() - p.x();
      if (dx * dx > best2) break;
      best2 = std::min(best2, (*f - p).squaredNorm());
    }
    for (auto b = it; b != gt.begin();) {
      --b;
      const double dx = p.x() - b->x();
      if (dx * dx > best2) break;
      best2 = std::min(best2, (*b - p).squaredNorm());
    }
    out.push_back(std::sqrt(best2));
  }
  return out;
}

}  // namespace loopd
