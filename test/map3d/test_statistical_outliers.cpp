// Statistical outliers (the idea of PCL's StatisticalOutlierRemoval): isolated far points found on a dense patch,
// the skip mask respected, the same result for any thread count.
#include <catch2/catch.hpp>
#include <random>

#include "loopd/map3d/statistical_outliers.hpp"

using namespace loopd;

namespace {
constexpr std::size_t kFar = 50;

// A 10 x 10 m patch at 5 cm with +-1 cm jitter, then kFar isolated points 5-50 m above a 100 x 100 m square.
PointCloud patch_with_far_points() {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> jitter(-0.01f, 0.01f), far_xy(-50.f, 50.f), far_z(5.f, 50.f);
  PointCloud cloud;
  for (int i = 0; i < 200; ++i) {
    for (int j = 0; j < 200; ++j)
      cloud.points.emplace_back(0.05f * static_cast<float>(i) + jitter(rng), 0.05f * static_cast<float>(j) + jitter(rng), jitter(rng));
  }
  for (std::size_t k = 0; k < kFar; ++k) cloud.points.emplace_back(far_xy(rng), far_xy(rng), far_z(rng));
  return cloud;
}
}  // namespace

TEST_CASE("Statistical outliers: all isolated far points found, at most 1 % of a dense patch") {
  const PointCloud cloud = patch_with_far_points();
  const std::size_t patch = cloud.size() - kFar;
  const auto outlier = find_statistical_outliers(cloud, StatisticalOutlierConfig{});
  REQUIRE(outlier.size() == cloud.size());
  std::size_t patch_marked = 0, far_marked = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) (i < patch ? patch_marked : far_marked) += outlier[i];
  CHECK(far_marked == kFar);
  CHECK(patch_marked <= patch / 100);
}

TEST_CASE("Statistical outliers: skipped points are neither tested nor marked, and results do not depend on threads") {
  const PointCloud cloud = patch_with_far_points();
  const std::size_t patch = cloud.size() - kFar;
  std::vector<std::uint8_t> skip(cloud.size(), 0);
  for (std::size_t k = 0; k < 10; ++k) skip[patch + k] = 1;
  StatisticalOutlierConfig config;
  config.num_threads = 1;
  const auto serial = find_statistical_outliers(cloud, config, &skip);
  config.num_threads = 2;
  const auto parallel = find_statistical_outliers(cloud, config, &skip);
  CHECK(serial == parallel);
  for (std::size_t k = 0; k < kFar; ++k) CHECK(serial[patch + k] == (k < 10 ? 0 : 1));
}

TEST_CASE("Statistical outliers: invalid settings, a wrong-size mask and tiny clouds mark nothing") {
  StatisticalOutlierConfig config;
  config.neighbours = 0;
  REQUIRE(config.validate());
  CHECK(config.validate()->find("neighbours") != std::string::npos);
  const PointCloud cloud = patch_with_far_points();
  CHECK(find_statistical_outliers(cloud, config) == std::vector<std::uint8_t>(cloud.size(), 0));
  const std::vector<std::uint8_t> short_mask(3, 0);
  CHECK(find_statistical_outliers(cloud, StatisticalOutlierConfig{}, &short_mask) == std::vector<std::uint8_t>(cloud.size(), 0));
  PointCloud tiny;
  for (int i = 0; i < 8; ++i) tiny.points.emplace_back(static_cast<float>(i), 0.f, 0.f);
  CHECK(find_statistical_outliers(tiny, StatisticalOutlierConfig{}) == std::vector<std::uint8_t>(8, 0));
}
