// M2DP tests: every case runs on both backends (GENERATE), and the OpenCL results are compared with the
// CPU reference (the oracle) component by component.
#include <catch2/catch.hpp>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/lidar_model.hpp"
#include "loopd/descriptor/m2dp.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"
#include "support/data_dir.hpp"

using namespace loopd;

namespace {

M2dpConfig config_for(Backend backend, M2dpFrame frame = M2dpFrame::kGravityAligned) {
  M2dpConfig c;
  c.max_points = 0;  // bin all points: the backends must agree on full 120k-point clouds
  c.backend = backend;
  c.frame = frame;
  c.log_fallback = false;  // a missing device is a test failure, not a silent CPU run
  return c;
}

const Town& test_town() {
  static const Town town = make_town(7);
  return town;
}

/// HDL-64E scan in the test town (about 110-130k points).
PointCloud town_scan(double x, double y, double yaw_deg, std::uint64_t seed = 1) {
  const Eigen::Isometry3d T = ground_pose(test_town(), x, y, yaw_deg * M_PI / 180.0);
  return simulate_scan(test_town(), lidar_model_hdl64(), T, seed, 2);
}

const PointCloud& base_scan() {
  static const PointCloud scan = town_scan(test_town().node(0, 0).x() + 20.0, test_town().node(0, 0).y() - 2.0, 0.0);
  return scan;
}

std::vector<Eigen::Vector3f> every_nth(const std::vector<Eigen::Vector3f>& pts, std::size_t target) {
  std::vector<Eigen::Vector3f> out;
  const std::size_t stride = std::max<std::size_t>(1, pts.size() / target);
  for (std::size_t i = 0; i < pts.size() && out.size() < target; i += stride) out.push_back(pts[i]);
  return out;
}

std::vector<Eigen::Vector3f> transformed(const std::vector<Eigen::Vector3f>& pts, double yaw_deg, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = t;
  std::vector<Eigen::Vector3f> out;
  out.reserve(pts.size());
  for (const auto& p : pts) out.push_back((T * p.cast<double>()).cast<float>());
  return out;
}

float max_abs_diff(const Eigen::VectorXf& a, const Eigen::VectorXf& b) { return (a - b).cwiseAbs().maxCoeff(); }

}  // namespace

TEST_CASE("M2dpConfig defaults follow the paper and validate") {
  const M2dpConfig c;
  CHECK(c.num_rings_l == 8);
  CHECK(c.num_sectors_t == 16);
  CHECK(c.num_azimuths_p == 4);
  CHECK(c.num_elevations_q == 16);
  CHECK(c.descriptor_size() == 192);
  CHECK_FALSE(c.validate().has_value());
  M2dpConfig odd = c;
  odd.num_sectors_t = 15;
  CHECK(odd.validate().has_value());
  M2dpConfig big = c;
  big.num_rings_l = 32;
  big.num_sectors_t = 16;
  CHECK(big.validate().has_value());  // 512 bins > 256
  CHECK_THROWS_AS(M2dp(odd), std::invalid_argument);
}

TEST_CASE("OpenCL backend matches the CPU reference on 1k, 30k and 120k points") {
  const M2dpFrame frame = GENERATE(M2dpFrame::kPca, M2dpFrame::kGravityAligned);
  const M2dp cpu(config_for(Backend::kCpu, frame));
  const M2dp ocl(config_for(Backend::kOpenCl, frame));
  REQUIRE(ocl.backend() == Backend::kOpenCl);
  const std::size_t n = GENERATE(std::size_t{1000}, std::size_t{30000}, std::size_t{120000});
  std::vector<Eigen::Vector3f> pts = every_nth(base_scan().points, n);
  // Top up to exactly n with a second scan of a nearby place (the base scan alone has about 120k points).
  if (pts.size() < n) {
    const PointCloud extra = town_scan(test_town().node(0, 0).x() + 25.0, test_town().node(0, 0).y() - 2.0, 10.0, 2);
    for (std::size_t i = 0; pts.size() < n && i < extra.size(); ++i) pts.push_back(extra.points[i]);
  }
  REQUIRE(pts.size() == n);
  const M2dpResult a = cpu.compute(pts), b = ocl.compute(pts);
  REQUIRE(a.ok);
  REQUIRE(b.ok);
  CHECK(a.backend == Backend::kCpu);
  CHECK(b.backend == Backend::kOpenCl);
  REQUIRE(a.descriptor.size() == 192);
  REQUIRE(b.descriptor.size() == 192);
  CHECK(a.descriptor.allFinite());
  CHECK(max_abs_diff(a.descriptor, b.descriptor) <= 1e-4f);
  CHECK(a.descriptor.head(64).norm() == Approx(1.0).epsilon(1e-5));
  CHECK(a.descriptor.tail(128).norm() == Approx(1.0).epsilon(1e-5));
  CHECK(a.descriptor.minCoeff() >= 0.0f);  // canonical sign: non-negative Perron vectors
}

TEST_CASE("M2DP is invariant to yaw and translation of the same scan, far below other places") {
  const Backend backend = GENERATE(Backend::kCpu, Backend::kOpenCl);
  const M2dpFrame frame = GENERATE(M2dpFrame::kPca, M2dpFrame::kGravityAligned);
  const M2dp m2dp(config_for(backend, frame));
  const M2dp oracle(config_for(Backend::kCpu, frame));
  const M2dpResult base = m2dp.compute(base_scan());
  REQUIRE(base.ok);
  CHECK(max_abs_diff(base.descriptor, oracle.compute(base_scan()).descriptor) <= 1e-4f);

  // Scans of other places in the same town (two blocks away and more).
  float nearest_other = std::numeric_limits<float>::infinity();
  const Eigen::Vector2d others[] = {test_town().node(2, 0) + Eigen::Vector2d(20, -2), test_town().node(0, 2) + Eigen::Vector2d(-2, 25),
                                    test_town().node(2, 2) + Eigen::Vector2d(15, -2)};
  for (const auto& o : others) {
    const M2dpResult r = m2dp.compute(town_scan(o.x(), o.y(), 0.0, 3));
    REQUIRE(r.ok);
    nearest_other = std::min(nearest_other, descriptor_distance(base.descriptor, r.descriptor));
  }
  float worst_same = 0.0f;
  for (double yaw : {30.0, 90.0, 180.0}) {
    const M2dpResult r = m2dp.compute(transformed(base_scan().points, yaw, Eigen::Vector3d(2.0, 0.0, 0.0)));
    REQUIRE(r.ok);
    worst_same = std::max(worst_same, descriptor_distance(base.descriptor, r.descriptor));
  }
  std::cout << "[m2dp] invariance " << to_string(backend) << "/" << to_string(frame) << ": same scan rotated+translated max distance " << worst_same
            << ", nearest other place " << nearest_other << "\n";
  CHECK(worst_same < 0.01f);
  CHECK(nearest_other > 10.0f * worst_same);
  CHECK(nearest_other > 0.05f);
}

TEST_CASE("M2DP returns a clear error on degenerate input") {
  const Backend backend = GENERATE(Backend::kCpu, Backend::kOpenCl);
  const M2dp m2dp(config_for(backend));
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<std::pair<std::string, std::vector<Eigen::Vector3f>>> cases = {
      {"empty", {}},
      {"one point", {{1, 2, 3}}},
      {"two points", {{1, 2, 3}, {4, 5, 6}}},
      {"all equal", std::vector<Eigen::Vector3f>(5000, Eigen::Vector3f(3.f, -1.f, 0.5f))},
      {"NaN", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {nan, 0, 0}, {0, 0, 1}}},
      {"Inf", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, inf, 0}, {0, 0, 1}}},
  };
  std::vector<Eigen::Vector3f> line;
  for (int i = 0; i < 20000; ++i) line.emplace_back(10.f + 0.01f * i, 5.f - 0.02f * i, 1.f + 0.005f * i);
  cases.emplace_back("collinear", line);
  std::vector<Eigen::Vector3f> vertical;
  for (int i = 0; i < 1000; ++i) vertical.emplace_back(4.f, 2.f, 0.01f * i);
  cases.emplace_back("collinear vertical", vertical);
  std::vector<Eigen::Vector3f> nan_in_big = every_nth(base_scan().points, 30000);
  nan_in_big[12345] = Eigen::Vector3f(nan, nan, nan);
  cases.emplace_back("NaN in a real scan", nan_in_big);
  for (const auto& [name, pts] : cases) {
    INFO(name << " on " << to_string(backend));
    const M2dpResult r = m2dp.compute(pts);
    CHECK_FALSE(r.ok);
    CHECK_FALSE(r.error.empty());
    CHECK(r.descriptor.size() == 0);
  }
  // Three non-collinear points are enough.
  const M2dpResult tri = m2dp.compute(std::vector<Eigen::Vector3f>{{0, 0, 0}, {2, 0, 0.5f}, {0, 1, 0}});
  CHECK(tri.ok);
  CHECK(tri.descriptor.allFinite());
}

TEST_CASE("M2DP on real KITTI revisits: PCA frame vs gravity-aligned frame") {
  LOOPD_REQUIRE_DATA(f0, "kitti/seq00/000000.bin");
  LOOPD_REQUIRE_DATA(f15, "kitti/seq00/000015.bin");
  LOOPD_REQUIRE_DATA(f94, "kitti/seq00/000094.bin");
  LOOPD_REQUIRE_DATA(f95, "kitti/seq00/000095.bin");
  LOOPD_REQUIRE_DATA(f198, "kitti/seq00/000198.bin");
  const Backend backend = GENERATE(Backend::kCpu, Backend::kOpenCl);
  std::vector<PointCloud> scans(5);
  const std::string files[] = {f0, f15, f94, f95, f198};
  for (int i = 0; i < 5; ++i) {
    CloudFile read = read_cloud_file(files[i]);
    REQUIRE(read.ok);
    scans[i] = std::move(read.cloud);
  }
  for (M2dpFrame frame : {M2dpFrame::kPca, M2dpFrame::kGravityAligned}) {
    const M2dp m2dp(config_for(backend, frame));
    const M2dp oracle(config_for(Backend::kCpu, frame));
    std::vector<Eigen::VectorXf> d;
    for (const auto& s : scans) {
      const M2dpResult r = m2dp.compute(s);
      REQUIRE(r.ok);
      CHECK(max_abs_diff(r.descriptor, oracle.compute(s).descriptor) <= 1e-4f);
      d.push_back(r.descriptor);
    }
    const float d_94_95 = descriptor_distance(d[2], d[3]), d_0_15 = descriptor_distance(d[0], d[1]);
    const float d_0_94 = descriptor_distance(d[0], d[2]), d_0_198 = descriptor_distance(d[0], d[4]), d_94_198 = descriptor_distance(d[2], d[4]);
    std::cout << "[m2dp] KITTI " << to_string(frame) << ": d(94,95)=" << d_94_95 << " d(0,15)=" << d_0_15 << " d(0,94)=" << d_0_94
              << " d(0,198)=" << d_0_198 << " d(94,198)=" << d_94_198 << "\n";
    // Consecutive scans (0.86 m apart) are nearer than scans of different streets.
    CHECK(d_94_95 < d_0_94);
    CHECK(d_94_95 < d_94_198);
  }
}
