#include "loopd/base/scene_scale.hpp"

#include "loopd/base/fast_atan2.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace loopd {
namespace {

constexpr int kSectors = 72;        // 5 deg of azimuth each
constexpr float kMinAbove = -0.3f;  // [m] returns at least this high in the sensor frame are not the ground
constexpr int kMinSectors = 6;      // fewer sectors see anything at sensor height: the median range instead
constexpr float kMin2 = 1.0f, kMax2 = 200.0f * 200.0f;

float median(std::vector<float>& v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

double scene_scale(const PointCloud& scan) {
  std::array<float, kSectors> horizon{};
  std::vector<float> all;
  all.reserve(4097);
  // Up to 32k returns (every one of a VLP-16 or a handheld scan, every 5th of an HDL-64E's): the farthest per 5 deg
  // moves little, its median over directions less. Odd strides: no aliasing with power-of-two ring counts.
  std::size_t step = scan.size() / 32768 + 1;
  if (step % 2 == 0) ++step;
  std::size_t stride = (scan.size() / step) / 4096 + 1;
  if (stride % 2 == 0) ++stride;
  for (std::size_t i = 0, k = 0; i < scan.size(); i += step, ++k) {
    const Eigen::Vector3f& p = scan.points[i];
    const float r2 = p.squaredNorm();
    if (!(r2 >= kMin2 && r2 <= kMax2)) continue;  // NaN fails too
    const float h = std::sqrt(p.x() * p.x() + p.y() * p.y());
    if (k % stride == 0) all.push_back(h);
    if (p.z() < kMinAbove) continue;
    const float az = fast_atan2(p.y(), p.x()) * static_cast<float>(kSectors / (2.0 * M_PI)) + kSectors / 2.0f;
    float& sector = horizon[static_cast<std::size_t>(std::clamp(static_cast<int>(az), 0, kSectors - 1))];
    sector = std::max(sector, h);
  }
  std::vector<float> seen;
  for (const float h : horizon)
    if (h > 0.f) seen.push_back(h);
  if (static_cast<int>(seen.size()) >= kMinSectors) return median(seen);
  return all.empty() ? 0.0 : median(all);
}

}  // namespace loopd
