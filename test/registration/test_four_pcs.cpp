// Plane-based 4PCS (Vlaminck 2019, Sec. 4.2) on simulated revisits of the procedural town: any heading, 2 m offset,
// parked cars moved between the visits.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "loopd/base/lidar_model.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/pipeline/register_scans.hpp"
#include "loopd/registration/radius_grid.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"

using namespace loopd;

namespace {
constexpr double kDeg = M_PI / 180.0;

double rot_err_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) { return rotation_angle(a.inverse() * b) / kDeg; }
double trans_err(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) { return (a.translation() - b.translation()).norm(); }

const Town& town() {
  static const Town t = make_town(1);
  return t;
}

struct Revisit {
  PreparedScan query, match;
  Eigen::Isometry3d T_match_query;
};

// Match: visit 0 at a street pose; query: visit 1 (parked cars moved or gone) 2 m away (1.41 m along x and y),
// heading turned by yaw_deg.
Revisit make_revisit(const LidarModel& model, int place, double yaw_deg, const ScanRegistrationConfig& cfg) {
  const Eigen::Isometry3d A = street_pose(town(), place, 1, place % 2, 25.0);
  const double yaw_a = std::atan2(A.linear()(1, 0), A.linear()(0, 0));
  const Eigen::Isometry3d B = ground_pose(town(), A.translation().x() + 1.41, A.translation().y() + 1.41, yaw_a + yaw_deg * kDeg);
  Revisit r;
  r.match = prepare_scan(simulate_scan(town(), model, A, 7, 1, 0), &model, cfg.prepare);
  r.query = prepare_scan(simulate_scan(town(), model, B, 11, 1, 1), &model, cfg.prepare);
  r.T_match_query = A.inverse() * B;
  return r;
}

FourPcsResult align(const Revisit& r, const FourPcsConfig& cfg) {
  return align_four_pcs(r.query.points, r.query.segmentation, r.match.points, r.match.segmentation, cfg);
}
}  // namespace

TEST_CASE("FourPcsConfig::validate rejects bad settings") {
  FourPcsConfig c;
  CHECK_FALSE(c.validate());
  c.delta = 0;
  CHECK(c.validate());
  c = FourPcsConfig{};
  c.num_threads = 0;
  CHECK(c.validate());
  c = FourPcsConfig{};
  c.max_bases = 0;
  CHECK(c.validate());
  const FourPcsResult r = align_four_pcs({}, Segmentation{}, {}, Segmentation{}, c);
  CHECK_FALSE(r.success);
  CHECK(r.reason.find("invalid") != std::string::npos);
}

TEST_CASE("HDL-64E revisits at yaw 0/45/90/135/180 deg and 2 m offset are recovered within 5 deg and 0.5 m") {
  const LidarModel model = lidar_model_hdl64();
  const ScanRegistrationConfig cfg;
  for (double yaw : {0.0, 45.0, 90.0, 135.0, 180.0}) {
    const Revisit rv = make_revisit(model, 1, yaw, cfg);
    const FourPcsResult r = align(rv, cfg.four_pcs);
    INFO("yaw " << yaw << " reason '" << r.reason << "' lcp " << r.lcp_fraction << " bases " << r.bases_tried << " sets " << r.congruent_sets);
    REQUIRE(r.success);
    CHECK(rot_err_deg(r.T_target_source, rv.T_match_query) < 5.0);
    CHECK(trans_err(r.T_target_source, rv.T_match_query) < 0.5);
    CHECK(r.lcp_fraction > 0.6);
    CHECK(r.bases_tried >= 1);
    CHECK(r.congruent_sets >= 1);
  }
}

TEST_CASE("HDL-32E and VLP-16 revisits are recovered too") {
  const ScanRegistrationConfig cfg;
  for (const LidarModel& model : {lidar_model_hdl32(), lidar_model_vlp16()}) {
    for (double yaw : {0.0, 90.0, 180.0}) {
      const Revisit rv = make_revisit(model, 2, yaw, cfg);
      const FourPcsResult r = align(rv, cfg.four_pcs);
      INFO(model.name << " yaw " << yaw << " reason '" << r.reason << "' lcp " << r.lcp_fraction);
      REQUIRE(r.success);
      CHECK(rot_err_deg(r.T_target_source, rv.T_match_query) < 5.0);
      CHECK(trans_err(r.T_target_source, rv.T_match_query) < 0.5);
      CHECK(r.lcp_fraction > 0.6);
    }
  }
}

TEST_CASE("scans of different places end with a lower LCP than revisits") {
  // Measured on this town: revisits >= 0.75, the other town (same pattern, no common structure) <= 0.48.
  const LidarModel model = lidar_model_hdl64();
  const ScanRegistrationConfig cfg;
  const Town other = make_other_town(1);
  double min_same = 1.0, max_other = 0.0;
  for (int place : {1, 2}) {
    const Revisit rv = make_revisit(model, place, 90.0, cfg);
    const FourPcsResult same = align(rv, cfg.four_pcs);
    REQUIRE(same.success);
    min_same = std::min(min_same, same.lcp_fraction);
    const PreparedScan elsewhere =
        prepare_scan(simulate_scan(other, model, street_pose(other, place, 1, place % 2, 25.0), 13, 1, 0), &model, cfg.prepare);
    const FourPcsResult diff = align_four_pcs(elsewhere.points, elsewhere.segmentation, rv.match.points, rv.match.segmentation, cfg.four_pcs);
    max_other = std::max(max_other, diff.success ? diff.lcp_fraction : 0.0);
  }
  INFO("min LCP same place " << min_same << ", max LCP different place " << max_other);
  CHECK(min_same > 0.7);
  CHECK(max_other < 0.55);
  CHECK(min_same - max_other > 0.15);
}

TEST_CASE("the result is identical with 1 and 2 threads and on repeated runs") {
  const LidarModel model = lidar_model_hdl64();
  ScanRegistrationConfig cfg;
  const Revisit rv = make_revisit(model, 1, 135.0, cfg);
  cfg.four_pcs.num_threads = 1;
  const FourPcsResult a = align(rv, cfg.four_pcs);
  const FourPcsResult b = align(rv, cfg.four_pcs);
  cfg.four_pcs.num_threads = 2;
  const FourPcsResult c = align(rv, cfg.four_pcs);
  REQUIRE(a.success);
  for (const FourPcsResult* o : {&b, &c}) {
    CHECK(o->success == a.success);
    CHECK(o->T_target_source.matrix() == a.T_target_source.matrix());
    CHECK(o->lcp_fraction == a.lcp_fraction);
    CHECK(o->bases_tried == a.bases_tried);
    CHECK(o->congruent_sets == a.congruent_sets);
  }
}

TEST_CASE("degenerate input returns no alignment with a reason") {
  const FourPcsConfig cfg;
  const LidarModel model = lidar_model_hdl64();
  const PreparedScan good =
      prepare_scan(simulate_scan(town(), model, street_pose(town(), 1, 1, 1, 25.0), 7, 1, 0), &model, registration_prepare_config());
  REQUIRE(good.segmentation.num_planar() > 0);

  SECTION("fewer than 4 points") {
    const std::vector<Eigen::Vector3f> three = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    const FourPcsResult r = align_four_pcs(three, good.segmentation, good.points, good.segmentation, cfg);
    CHECK_FALSE(r.success);
    CHECK(r.reason.find("fewer than 4") != std::string::npos);
  }
  SECTION("no planes found (scattered points)") {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-20.f, 20.f);
    PointCloud blob;
    for (int i = 0; i < 20000; ++i) blob.points.emplace_back(u(rng), u(rng), u(rng) * 0.2f);
    const PreparedScan in = prepare_scan(blob, nullptr, registration_prepare_config());
    CHECK(in.segmentation.num_planar() == 0);
    const FourPcsResult r = align_four_pcs(in.points, in.segmentation, good.points, good.segmentation, cfg);
    CHECK_FALSE(r.success);
    CHECK(r.reason.find("no planar cluster") != std::string::npos);
    const FourPcsResult r2 = align_four_pcs(good.points, good.segmentation, in.points, in.segmentation, cfg);
    CHECK_FALSE(r2.success);
    CHECK(r2.reason.find("no planar cluster") != std::string::npos);
  }
  SECTION("all collinear: a plane whose hull is a segment gives no base") {
    Segmentation seg;
    Cluster cl;
    cl.planar = true;
    cl.num_points = 100;
    cl.plane = Eigen::Vector4f(0, 1, 0, -5);
    for (int i = 0; i < 10; ++i) cl.hull.emplace_back(static_cast<float>(i), 5.f, 0.f);
    cl.points = cl.hull;
    cl.centroid = Eigen::Vector3f(4.5f, 5.f, 0.f);
    seg.clusters.push_back(cl);
    const FourPcsResult r = align_four_pcs(cl.points, seg, good.points, good.segmentation, cfg);
    CHECK_FALSE(r.success);
    CHECK(r.reason.find("no coplanar base") != std::string::npos);
  }
  SECTION("empty segmentation") {
    const FourPcsResult r = align_four_pcs(good.points, Segmentation{}, good.points, good.segmentation, cfg);
    CHECK_FALSE(r.success);
    CHECK_FALSE(r.reason.empty());
  }
}

TEST_CASE("RadiusGrid returns exactly the points within the radius, wherever they lie", "[four_pcs][radius_grid]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> near(-3.f, 3.f), cell(0.f, 1.f);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 3000; ++i) pts.emplace_back(near(rng), near(rng), 0.2f * near(rng));
  // On cell boundaries (multiples of the radius), exactly at the radius from a query, and far away (keys that wrap).
  for (int i = -6; i <= 6; ++i) pts.emplace_back(0.5f * static_cast<float>(i), 0.5f, -0.5f);
  pts.emplace_back(0.5f, 0.f, 0.f);
  pts.emplace_back(1.0e6f, -2.0e6f, 3.0f);
  pts.emplace_back(1.0e6f + 0.1f, -2.0e6f, 3.0f);
  pts.emplace_back(-1048576.f, 0.f, 0.f);  // 2^21 cells from the origin: the same key as the origin's cell
  const float radius = 0.5f;
  const RadiusGrid grid(pts, radius);
  std::vector<Eigen::Vector3f> queries = {Eigen::Vector3f::Zero(), {1.0e6f, -2.0e6f, 3.0f}, {0.25f, 0.5f, -0.5f}, {-0.5f, 0.5f, -0.5f}};
  for (int i = 0; i < 500; ++i) queries.emplace_back(near(rng) + cell(rng), near(rng), 0.2f * near(rng));
  std::size_t total = 0;
  for (const Eigen::Vector3f& q : queries) {
    std::vector<int> got;
    grid.within(q, &got);
    std::sort(got.begin(), got.end());
    std::vector<int> want;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Eigen::Vector3f d = q - pts[i];
      float d2 = 0.f;
      d2 += d.x() * d.x();
      d2 += d.y() * d.y();
      d2 += d.z() * d.z();
      if (d2 < radius * radius) want.push_back(static_cast<int>(i));
    }
    REQUIRE(got == want);
    total += got.size();
  }
  CHECK(total > 5000);  // the queries land among the points, not beside them
  std::vector<int> none;
  RadiusGrid(std::vector<Eigen::Vector3f>{}, radius).within(Eigen::Vector3f::Zero(), &none);
  CHECK(none.empty());
}
