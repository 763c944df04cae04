#pragma once
#include <algorithm>
#include <cmath>

namespace loopd {

/// @brief atan2(y, x) [rad] with |error| <= 2.1e-4 rad (0.012 deg, largest near +-45 and +-135 deg; measured over 2M
/// directions): binning a point's azimuth into columns or sectors needs no more (an HDL-64E column is 0.17 deg), and
/// libm's atan2 dominated the range image's projection. 0 for (0, 0).
inline float fast_atan2(float y, float x) {
  const float ax = std::abs(x), ay = std::abs(y);
  const float mx = std::max(ax, ay);
  if (mx == 0.f) return 0.f;
  const float a = std::min(ax, ay) / mx;
  const float s = a * a;
  float r = ((-0.0464964749f * s + 0.15931422f) * s - 0.327622764f) * s * a + a;
  if (ay > ax) r = 1.57079637f - r;
  if (x < 0) r = 3.14159274f - r;
  return y < 0 ? -r : r;
}

}  // namespace loopd
