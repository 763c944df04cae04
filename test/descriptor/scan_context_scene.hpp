#pragma once
/// @file Street-like scenes for the Scan Context tests: ground around a sensor 1.8 m up, buildings (boxes) of random
/// size and height on both sides, poles. Deterministic for the seed; different seeds are different places.
#include <random>

#include "loopd/base/point_cloud.hpp"
#include "verify/synthetic_scene.hpp"

namespace loopd::test {

inline PointCloud scan_context_scene(std::uint32_t seed, int num_buildings = 14) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  PointCloud cloud;
  auto& pts = cloud.points;
  constexpr float kGround = -1.8f;   // sensor frame: the sensor 1.8 m above the road
  for (int i = 0; i < 20000; ++i) {  // ground, denser near the sensor like a spinning lidar's
    const float range = 2.f + 68.f * u(rng) * u(rng), a = 6.2831853f * u(rng);
    pts.emplace_back(range * std::cos(a), range * std::sin(a), kGround + 0.02f * (u(rng) - 0.5f));
  }
  for (int b = 0; b < num_buildings; ++b) {
    const float along = -60.f + 120.f * u(rng), side = (b % 2 ? 1.f : -1.f) * (7.f + 10.f * u(rng));
    const Eigen::Vector3f size(6.f + 14.f * u(rng), 5.f + 8.f * u(rng), 3.f + 15.f * u(rng));
    sample_box(&pts, Eigen::Vector3f(along, side, kGround), size, 400, &rng, 0.02f);
  }
  const std::size_t first_pole = pts.size();
  for (int p = 0; p < 10; ++p) sample_pole(&pts, -40.f + 80.f * u(rng), (p % 2 ? 5.f : -5.f) + u(rng), 0.2f, 4.f + 4.f * u(rng), 120, &rng, 0.02f);
  for (std::size_t i = first_pole; i < pts.size(); ++i) pts[i].z() += kGround;  // poles stand on the road
  return cloud;
}

}  // namespace loopd::test
