#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <tuple>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/lidar_model.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/base/stopwatch.hpp"
#include "loopd/io/kitti_files.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"
#include "loopd/pipeline/prepare_scan.hpp"
#include "loopd/verify/verify.hpp"
#include "support/data_dir.hpp"
#include "verify/synthetic_scene.hpp"

using namespace loopd;
using loopd::test::rotation_error_deg;
using loopd::test::translation_error;

namespace {

struct SimPair {
  std::string name;
  PreparedScan query, match;
  Eigen::Isometry3d T_match_query;  // ground truth
};

PreparedScan prepare_sim(const Town& town, const Eigen::Isometry3d& T_world_sensor, int visit, std::uint64_t seed) {
  static const LidarModel model = lidar_model_hdl64();
  const PointCloud scan = simulate_scan(town, model, T_world_sensor, seed, 2, visit);
  return prepare_scan(scan, &model, PrepareConfig{});
}

SimPair make_pair(const std::string& name, const Town& tq, const Eigen::Isometry3d& Tq, int visit_q, const Town& tm, const Eigen::Isometry3d& Tm,
                  int visit_m) {
  SimPair p;
  p.name = name;
  p.query = prepare_sim(tq, Tq, visit_q, 11);
  p.match = prepare_sim(tm, Tm, visit_m, 12);
  p.T_match_query = Tm.inverse() * Tq;
  return p;
}

void print(const SimPair& p, const VerifyResult& r) {
  std::printf(
      "%-28s acc=%d stage=%-10s lcp=%.2f res=%.3f fit=%.2f deg=%.1f hung=%.2f (%d/%d/%d) terr=%.3f rerr=%.2f ms=%.1f/%.1f/%.1f/%.1f pts=%zu/%zu "
      "bytes=%zu/%zu cl=%zu/%zu %s\n",
      p.name.c_str(), r.accepted, to_string(r.stage).c_str(), r.lcp_fraction, r.icp_residual, r.icp_fitness, r.degeneracy, r.hungarian_consistency,
      r.clusters_matched, r.clusters_query, r.clusters_match, translation_error(r.T_match_query, p.T_match_query),
      rotation_error_deg(r.T_match_query, p.T_match_query), r.ms_fourpcs, r.ms_gicp, r.ms_hungarian, r.ms_total, p.query.points.size(),
      p.match.points.size(), p.query.bytes(), p.match.bytes(), p.query.segmentation.clusters.size(), p.match.segmentation.clusters.size(),
      r.reason.c_str());
}

}  // namespace

namespace {
void check_true_loop(const SimPair& p, const VerifyResult& r) {
  INFO(p.name << ": stage " << to_string(r.stage) << " reason '" << r.reason << "' lcp " << r.lcp_fraction << " fitness " << r.icp_fitness
              << " residual " << r.icp_residual << " degeneracy " << r.degeneracy << " consistency " << r.hungarian_consistency);
  CHECK(r.accepted);
  CHECK(r.stage == VerifyStage::kAccepted);
  CHECK(translation_error(r.T_match_query, p.T_match_query) < 0.2);
  CHECK(rotation_error_deg(r.T_match_query, p.T_match_query) < 1.0);
  CHECK(r.information.allFinite());
  CHECK(r.information.trace() > 0.0);
  CHECK(r.ms_total >= r.ms_gicp);
}
}  // namespace

TEST_CASE("prepare_scan keeps an HDL-64E town scan within the keyframe memory budget") {
  const Town town = make_town(1);
  const PreparedScan s = prepare_sim(town, street_pose(town, 0, 0, 0, 22.0), 0, 1);
  INFO("points " << s.points.size() << " clusters " << s.segmentation.clusters.size() << " bytes " << s.bytes());
  CHECK(s.error.empty());
  CHECK(s.points.size() > 2000);
  CHECK(s.points.size() <= PrepareConfig{}.max_points);
  CHECK(s.normals.size() == s.points.size());
  CHECK(s.bytes() <= 125 * 1024);
  CHECK(s.input_points > 100000);
  bool all_finite_in_range = true;
  for (const auto& p : s.points) all_finite_in_range = all_finite_in_range && p.allFinite() && p.norm() > 1.5f && p.norm() < 61.f;
  CHECK(all_finite_in_range);
}

TEST_CASE("range-image GICP normals agree with k-nearest-neighbour normals where the surface is smooth") {
  const Town town = make_town(1);
  const LidarModel model = lidar_model_hdl64();
  const PointCloud scan = simulate_scan(town, model, street_pose(town, 0, 0, 0, 22.0), 1, 2, 0);
  PrepareConfig range_cfg;  // default: normals from the segmentation's range image
  PrepareConfig knn_cfg;
  knn_cfg.range_image_normal_coherence = 0.0;  // PCA of the k nearest voxel centroids
  knn_cfg.normal_k_neighbors = 10;
  REQUIRE(range_cfg.range_image_normal_coherence > 0.0);
  const PreparedScan r = prepare_scan(scan, &model, range_cfg), k = prepare_scan(scan, &model, knn_cfg);
  REQUIRE(r.points.size() == k.points.size());  // same voxels either way
  const auto rn = r.unpacked_normals(), kn = k.unpacked_normals();
  REQUIRE(rn.size() == r.points.size());
  std::vector<double> angles;
  std::size_t with_normal = 0;
  for (std::size_t i = 0; i < rn.size(); ++i) {
    CHECK(r.points[i].isApprox(k.points[i]));
    if (rn[i].isZero()) continue;
    ++with_normal;
    CHECK(std::abs(rn[i].norm() - 1.f) < 0.01f);
    if (!kn[i].isZero()) angles.push_back(std::acos(std::min(1.0, static_cast<double>(std::abs(rn[i].dot(kn[i]))))) * 180.0 / M_PI);
  }
  std::sort(angles.begin(), angles.end());
  REQUIRE(!angles.empty());
  const double share = static_cast<double>(with_normal) / static_cast<double>(rn.size());
  const double median = angles[angles.size() / 2], p75 = angles[angles.size() * 3 / 4];
  INFO("voxels " << rn.size() << ", with a range-image normal " << share << ", angle to the kNN normal median " << median << " deg, p75 " << p75);
  CHECK(share > 0.6);  // walls, ground and car bodies; edges, corners and trees get none
  CHECK(median < 5.0);
  CHECK(p75 < 10.0);
}

TEST_CASE("true revisits are accepted with the final transform within 0.2 m and 1 deg") {
  const Town town = make_town(1);
  const Eigen::Isometry3d q0 = street_pose(town, 0, 0, 0, 22.0);
  const Eigen::Vector3d p = q0.translation();
  const double yaw = std::atan2(q0.linear()(1, 0), q0.linear()(0, 0));
  // Visits 1 and 2 show the parked cars marked movable moved or gone (sim: movable_fraction 0.5).
  std::vector<SimPair> pairs;
  pairs.push_back(make_pair("same direction, 1 m, moved cars", town, q0, 0, town, street_pose(town, 0, 0, 0, 23.0), 1));
  pairs.push_back(make_pair("opposite direction, other lane", town, q0, 0, town, ground_pose(town, p.x() + 0.5, p.y() + 4.0, yaw + M_PI), 1));
  pairs.push_back(make_pair("3 m lane offset", town, q0, 0, town, street_pose(town, 0, 0, 0, 22.5, -2.0 + 3.0), 2));
  pairs.push_back(make_pair("north street, moved cars", town, street_pose(town, 2, 0, 1, 28.0), 0, town, street_pose(town, 2, 0, 1, 28.7, -1.5), 1));
  for (const auto& pr : pairs) check_true_loop(pr, verify(pr.query, pr.match, VerifyConfig{}));
}

TEST_CASE("near misses are rejected") {
  const Town town = make_town(1);
  const Eigen::Isometry3d q0 = street_pose(town, 0, 0, 0, 22.0);
  SECTION("a different town built to the same pattern") {
    const Town other = make_other_town(1);
    for (const auto& pr :
         {make_pair("other town", town, q0, 0, other, street_pose(other, 0, 0, 0, 22.0), 0),
          make_pair("other town, north street", town, street_pose(town, 2, 0, 1, 28.0), 0, other, street_pose(other, 2, 0, 1, 28.0), 0)}) {
      const VerifyResult r = verify(pr.query, pr.match, VerifyConfig{});
      INFO(pr.name << ": stage " << to_string(r.stage) << " reason " << r.reason << " consistency " << r.hungarian_consistency);
      CHECK_FALSE(r.accepted);
      CHECK_FALSE(r.reason.empty());
      // Also from the best possible start (same street coordinates) nothing is accepted.
      const VerifyResult g = verify_from_guess(pr.query, pr.match, pr.T_match_query, VerifyConfig{});
      INFO("from guess: stage " << to_string(g.stage) << " reason " << g.reason);
      CHECK_FALSE(g.accepted);
    }
  }
  SECTION("a featureless tunnel shifted 6 m along its axis: degenerate, rejected at the degeneracy stage") {
    const Town corridor = make_corridor();
    const SimPair pr =
        make_pair("tunnel", corridor, street_pose(corridor, 0, 0, 0, 0.0, 0.0), 0, corridor, street_pose(corridor, 0, 0, 0, 6.0, 0.0), 0);
    for (const VerifyResult& r :
         {verify(pr.query, pr.match, VerifyConfig{}), verify_from_guess(pr.query, pr.match, Eigen::Isometry3d::Identity(), VerifyConfig{})}) {
      INFO("stage " << to_string(r.stage) << " reason " << r.reason << " degeneracy " << r.degeneracy);
      CHECK_FALSE(r.accepted);
      if (r.stage != VerifyStage::kFourPcs) {
        CHECK(r.stage == VerifyStage::kDegeneracy);
        CHECK(r.degenerate);
        CHECK(r.degeneracy > VerifyConfig{}.max_degeneracy_ratio);
        CHECK(std::abs(r.weakest_direction.x()) > 0.9);  // along the tunnel axis
      }
    }
    // With rejection switched off it is flagged instead.
    VerifyConfig flag_only;
    flag_only.reject_degenerate = false;
    const VerifyResult f = verify_from_guess(pr.query, pr.match, Eigen::Isometry3d::Identity(), flag_only);
    CHECK(f.degenerate);
    CHECK(f.stage != VerifyStage::kDegeneracy);
  }
  SECTION("4PCS result perturbed by 3 m: GICP and the checks either recover the truth or reject") {
    const Eigen::Vector3d p = q0.translation();
    const double yaw = std::atan2(q0.linear()(1, 0), q0.linear()(0, 0));
    for (const auto& pr : {make_pair("same direction", town, q0, 0, town, street_pose(town, 0, 0, 0, 23.0), 1),
                           make_pair("opposite", town, q0, 0, town, ground_pose(town, p.x() + 0.5, p.y() + 4.0, yaw + M_PI), 1)}) {
      for (const Eigen::Vector3d& off : {Eigen::Vector3d(3, 0, 0), Eigen::Vector3d(0, 3, 0), Eigen::Vector3d(-2.1, 2.1, 0)}) {
        const Eigen::Isometry3d bad = pr.T_match_query * make_isometry(off.x(), off.y(), off.z(), 0.0);
        const VerifyResult r = verify_from_guess(pr.query, pr.match, bad, VerifyConfig{});
        const double te = translation_error(r.T_match_query, pr.T_match_query);
        INFO(pr.name << " offset " << off.transpose() << ": accepted " << r.accepted << " stage " << to_string(r.stage) << " reason " << r.reason
                     << " terr " << te);
        if (r.accepted) {
          CHECK(te < 0.2);
          CHECK(rotation_error_deg(r.T_match_query, pr.T_match_query) < 1.0);
        } else {
          CHECK_FALSE(r.reason.empty());
        }
      }
    }
  }
}

TEST_CASE("degenerate and hostile input is rejected with a reason, never a crash") {
  const Town town = make_town(1);
  const PreparedScan good = prepare_sim(town, street_pose(town, 0, 0, 0, 22.0), 0, 1);
  const LidarModel model = lidar_model_hdl64();
  SECTION("empty scan") {
    const PreparedScan empty = prepare_scan(PointCloud{}, &model, PrepareConfig{});
    CHECK_FALSE(empty.error.empty());
    const VerifyResult r = verify(empty, good, VerifyConfig{});
    CHECK_FALSE(r.accepted);
    CHECK(r.stage == VerifyStage::kInput);
    CHECK_FALSE(r.reason.empty());
    CHECK_FALSE(verify(good, PreparedScan{}, VerifyConfig{}).accepted);
  }
  SECTION("all-NaN and partly NaN scans") {
    PointCloud nan_scan;
    nan_scan.points.assign(5000, Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
    const PreparedScan n = prepare_scan(nan_scan, &model, PrepareConfig{});
    CHECK_FALSE(n.error.empty());
    const VerifyResult r = verify(n, good, VerifyConfig{});
    CHECK_FALSE(r.accepted);
    CHECK(r.stage == VerifyStage::kInput);
    PointCloud mixed = simulate_scan(town, model, street_pose(town, 0, 0, 0, 23.0), 2, 2, 0);
    for (std::size_t i = 0; i < mixed.points.size(); i += 5) mixed.points[i] = Eigen::Vector3f(NAN, 1, INFINITY);
    const PreparedScan m = prepare_scan(mixed, &model, PrepareConfig{});
    for (const auto& p : m.points) REQUIRE(p.allFinite());
    CHECK(m.finite_points < m.input_points);
  }
  SECTION("all points equal") {
    PointCloud same;
    same.points.assign(3000, Eigen::Vector3f(5, 5, 0));
    const PreparedScan s = prepare_scan(same, &model, PrepareConfig{});
    const VerifyResult r = verify(s, good, VerifyConfig{});
    CHECK_FALSE(r.accepted);
    CHECK_FALSE(r.reason.empty());
    const VerifyResult r2 = verify(s, s, VerifyConfig{});
    CHECK_FALSE(r2.accepted);
    CHECK_FALSE(r2.reason.empty());
    const VerifyResult r3 = verify_from_guess(s, s, Eigen::Isometry3d::Identity(), VerifyConfig{});
    CHECK_FALSE(r3.accepted);
  }
  SECTION("invalid config and non-finite guess") {
    VerifyConfig bad;
    bad.min_icp_fitness = 2.0;
    CHECK(bad.validate());
    const VerifyResult r = verify(good, good, bad);
    CHECK_FALSE(r.accepted);
    CHECK(r.stage == VerifyStage::kInput);
    Eigen::Isometry3d nan_guess = Eigen::Isometry3d::Identity();
    nan_guess(0, 3) = NAN;
    CHECK_FALSE(verify_from_guess(good, good, nan_guess, VerifyConfig{}).accepted);
  }
}

namespace {

PreparedScan prepare_kitti(const std::string& file) {
  static const LidarModel model = lidar_model_hdl64();
  const CloudFile read = read_kitti_bin(file);
  REQUIRE(read.ok);
  return prepare_scan(read.cloud, &model, PrepareConfig{});
}
}  // namespace

TEST_CASE("real KITTI seq 00: same place accepted within 0.2 m / 1 deg of ground truth, different places rejected") {
  LOOPD_REQUIRE_DATA(poses_file, "kitti/poses/00.txt");
  LOOPD_REQUIRE_DATA(calib_file, "kitti/calib/Tr_velo_to_cam_00-02.txt");
  LOOPD_REQUIRE_DATA(f0, "kitti/seq00/000000.bin");
  LOOPD_REQUIRE_DATA(f94, "kitti/seq00/000094.bin");
  LOOPD_REQUIRE_DATA(f95, "kitti/seq00/000095.bin");
  LOOPD_REQUIRE_DATA(f198, "kitti/seq00/000198.bin");
  LOOPD_REQUIRE_DATA(f199, "kitti/seq00/000199.bin");
  const TrajectoryFile kitti = read_kitti_lidar_poses(poses_file, calib_file);
  REQUIRE(kitti.ok);
  const std::vector<Eigen::Isometry3d>& velo_poses = kitti.poses;  // T_world_velo
  const PreparedScan s0 = prepare_kitti(f0), s94 = prepare_kitti(f94), s95 = prepare_kitti(f95), s198 = prepare_kitti(f198),
                     s199 = prepare_kitti(f199);
  CHECK(s94.bytes() <= 125 * 1024);
  // Same place (consecutive frames; the README checks these two against the ground truth to mm).
  for (const auto& [q, m, qi, mi] : {std::tuple<const PreparedScan*, const PreparedScan*, int, int>{&s95, &s94, 95, 94}, {&s199, &s198, 199, 198}}) {
    const Eigen::Isometry3d Tq = velo_poses.at(static_cast<std::size_t>(qi));
    const Eigen::Isometry3d Tm = velo_poses.at(static_cast<std::size_t>(mi));
    const Eigen::Isometry3d truth = Tm.inverse() * Tq;
    const VerifyResult r = verify(*q, *m, VerifyConfig{});
    INFO(qi << "->" << mi << " stage " << to_string(r.stage) << " reason " << r.reason << " t " << r.T_match_query.translation().transpose()
            << " truth " << truth.translation().transpose());
    CHECK(r.accepted);
    CHECK(translation_error(r.T_match_query, truth) < 0.2);
    CHECK(rotation_error_deg(r.T_match_query, truth) < 1.0);
  }
  // Different places of the same town (hundreds of metres apart): rejected with 4PCS, and also from an identity guess.
  for (const auto& [q, m] : {std::pair<const PreparedScan*, const PreparedScan*>{&s0, &s198}, {&s94, &s198}, {&s199, &s0}}) {
    const VerifyResult r = verify(*q, *m, VerifyConfig{});
    INFO("stage " << to_string(r.stage) << " reason " << r.reason);
    CHECK_FALSE(r.accepted);
    const VerifyResult g = verify_from_guess(*q, *m, Eigen::Isometry3d::Identity(), VerifyConfig{});
    INFO("from identity: stage " << to_string(g.stage) << " reason " << g.reason);
    CHECK_FALSE(g.accepted);
  }
}

TEST_CASE("to_string names every stage") {
  CHECK(to_string(VerifyStage::kInput) == "input");
  CHECK(to_string(VerifyStage::kFourPcs) == "fourpcs");
  CHECK(to_string(VerifyStage::kGicp) == "gicp");
  CHECK(to_string(VerifyStage::kDegeneracy) == "degeneracy");
  CHECK(to_string(VerifyStage::kHungarian) == "hungarian");
  CHECK(to_string(VerifyStage::kAccepted) == "accepted");
}

TEST_CASE("explore verify on simulated pairs", "[.explore]") {
  const Town town = make_town(1);
  const Town other = make_other_town(1);
  const Town corridor = make_corridor();
  const Eigen::Isometry3d q0 = street_pose(town, 0, 0, 0, 22.0);
  std::vector<SimPair> pairs;
  Stopwatch sw;
  pairs.push_back(make_pair("same-dir 1m moved-cars", town, q0, 0, town, street_pose(town, 0, 0, 0, 23.0), 1));
  std::printf("sim+prepare pair: %.1f ms\n", sw.ms());
  const Eigen::Vector3d p = q0.translation();
  const double yaw = std::atan2(q0.linear()(1, 0), q0.linear()(0, 0));
  pairs.push_back(make_pair("opposite-dir", town, q0, 0, town, ground_pose(town, p.x() + 0.5, p.y() + 4.0, yaw + M_PI), 1));
  pairs.push_back(make_pair("lane-offset 3m", town, q0, 0, town, street_pose(town, 0, 0, 0, 22.5, -2.0 + 3.0), 2));
  pairs.push_back(make_pair("other-town", town, q0, 0, other, street_pose(other, 0, 0, 0, 22.0), 0));
  pairs.push_back(
      make_pair("corridor 6m", corridor, street_pose(corridor, 0, 0, 0, 0.0, 0.0), 0, corridor, street_pose(corridor, 0, 0, 0, 6.0, 0.0), 0));
  for (int k = 1; k < 4; ++k) {
    const Eigen::Isometry3d qk = street_pose(town, k, 0, 1, 18.0 + 5 * k);
    pairs.push_back(make_pair("north " + std::to_string(k), town, qk, 0, town, street_pose(town, k, 0, 1, 18.7 + 5 * k, -1.5), 1));
  }
  VerifyConfig cfg;
  for (const auto& pr : pairs) {
    for (int k : {10, 20}) {
      Stopwatch g;
      GicpConfig gc = cfg.gicp;
      gc.num_threads = 1;
      gc.k_neighbors = k;
      const GicpResult gr = align_gicp(pr.query.points, pr.match.points, pr.T_match_query * make_isometry(0.3, 0.2, 0, 0.03), gc);
      std::printf("  k=%d gicp %.1f ms (cov %.1f) it=%d conv=%d terr=%.3f rerr=%.3f fit=%.3f res=%.3f deg=%.1f\n", k, g.ms(), gr.ms_covariances,
                  gr.iterations, gr.converged, translation_error(gr.T_target_source, pr.T_match_query),
                  rotation_error_deg(gr.T_target_source, pr.T_match_query), gr.fitness, gr.residual, gr.degeneracy);
    }
    if (std::getenv("GICP_ONLY")) continue;
    const VerifyResult r = verify(pr.query, pr.match, cfg);
    print(pr, r);
    SimPair bad = pr;
    bad.name += " +3m guess";
    const VerifyResult r3 = verify_from_guess(pr.query, pr.match, pr.T_match_query * make_isometry(3.0, 0, 0, 0.0), cfg);
    print(bad, r3);
    const VerifyResult rt = verify_from_guess(pr.query, pr.match, pr.T_match_query, cfg);
    bad.name = pr.name + " truth guess";
    print(bad, rt);
  }
}

TEST_CASE("explore clusters", "[.clusters]") {
  const Town town = make_town(1);
  const Town other = make_other_town(1);
  const Eigen::Isometry3d q0 = street_pose(town, 0, 0, 0, 22.0);
  const Eigen::Vector3d p = q0.translation();
  std::vector<SimPair> pairs;
  pairs.push_back(make_pair("same-dir 1m moved-cars", town, q0, 0, town, street_pose(town, 0, 0, 0, 23.0), 1));
  pairs.push_back(make_pair("opposite-dir", town, q0, 0, town, ground_pose(town, p.x() + 0.5, p.y() + 4.0, M_PI), 1));
  pairs.push_back(make_pair("other-town", town, q0, 0, other, street_pose(other, 0, 0, 0, 22.0), 0));
  for (const auto& pr : pairs) {
    std::printf("== %s\n", pr.name.c_str());
    for (const auto& c : pr.query.segmentation.clusters) {
      const Eigen::Vector3f q = pr.T_match_query.cast<float>() * c.centroid;
      double best = 1e9;
      const Cluster* bc = nullptr;
      for (const auto& m : pr.match.segmentation.clusters)
        if ((m.centroid - q).norm() < best) {
          best = (m.centroid - q).norm();
          bc = &m;
        }
      std::printf("  n=%5d planar=%d ext=%5.1f/%4.1f z=%5.1f r=%5.1f  nearest=%5.2f (n=%5d ext=%5.1f)\n", c.num_points, c.planar, c.extent_major,
                  c.extent_minor, c.centroid.z(), c.centroid.norm(), best, bc ? bc->num_points : 0, bc ? bc->extent_major : 0.f);
    }
  }
}
