// The degeneracy check on simulated mine scans (make_mine): a revisit along a featureless mid-tunnel stretch is
// degenerate along the roadway axis and rejected, a revisit at a junction is accepted with the right transform.
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <tuple>

#include "loopd/base/lidar_model.hpp"
#include "loopd/pipeline/prepare_scan.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/mine.hpp"
#include "loopd/verify/verify.hpp"
#include "verify/synthetic_scene.hpp"

using namespace loopd;
using loopd::test::rotation_error_deg;
using loopd::test::translation_error;

namespace {

struct MinePair {
  PreparedScan query, match;
  Eigen::Isometry3d T_match_query;  // ground truth
};

/// Two instantaneous scans of `model` on the centre line of the roadway leaving junction (i, j) in `direction`,
/// `along_q` and `along_m` metres from the junction (the match on a later visit: movable objects may have changed).
MinePair make_pair(const Town& mine, const LidarModel& model, int i, int j, int direction, double along_q, double along_m) {
  const Eigen::Isometry3d Tq = street_pose(mine, i, j, direction, along_q, 0.0);
  const Eigen::Isometry3d Tm = street_pose(mine, i, j, direction, along_m, 0.0);
  MinePair p;
  p.query = prepare_scan(simulate_scan(mine, model, Tq, 21, 2, 0), &model, PrepareConfig{});
  p.match = prepare_scan(simulate_scan(mine, model, Tm, 22, 2, 1), &model, PrepareConfig{});
  p.T_match_query = Tm.inverse() * Tq;
  return p;
}

std::string describe(const VerifyResult& r, const MinePair& p) {
  return "stage " + to_string(r.stage) + " reason '" + r.reason + "' degeneracy " + std::to_string(r.degeneracy) + " fitness " +
         std::to_string(r.icp_fitness) + " residual " + std::to_string(r.icp_residual) + " terr " +
         std::to_string(translation_error(r.T_match_query, p.T_match_query)) + " points " + std::to_string(p.query.points.size());
}

}  // namespace

TEST_CASE("mine: a revisit 4 m apart mid-tunnel is degenerate along the roadway and rejected", "[verify][mine][degeneracy]") {
  // A stretch is featureless only when no junction is within the keyframes' 60 m crop (PrepareConfig::max_range):
  // looking down a roadway, a chamber's far wall or a door frame 30-50 m away constrains the axis (degeneracy 7-85 in
  // the default mine, whose junctions are 60-100 m apart). So this mine has 150-160 m roadways: mid-tunnel, only rough
  // walls and roof are in range.
  MineConfig long_roadways;
  long_roadways.min_spacing = 150.0;
  long_roadways.max_spacing = 160.0;
  const Town mine = make_mine(long_roadways);
  const MineLayout layout = make_mine_layout(long_roadways);
  const double mid = 0.5 * (layout.line_x[1] - layout.line_x[0]);  // roadway (0,0)-(1,0), along +x
  for (const LidarModel& model : {lidar_model_vlp16(), lidar_model_hdl64()}) {
    const MinePair p = make_pair(mine, model, 0, 0, 0, mid - 2.0, mid + 2.0);
    const VerifyResult full = verify(p.query, p.match, VerifyConfig{});
    const VerifyResult truth = verify_from_guess(p.query, p.match, p.T_match_query, VerifyConfig{});
    INFO(model.name << " full: " << describe(full, p));
    INFO(model.name << " from the truth: " << describe(truth, p));
    CHECK_FALSE(full.accepted);
    CHECK_FALSE(truth.accepted);
    // Even started at the true transform the alignment is flagged: the axis is barely constrained.
    CHECK(truth.stage == VerifyStage::kDegeneracy);
    CHECK(truth.degenerate);
    CHECK(std::abs(truth.weakest_direction.x()) > 0.9);
  }
}

TEST_CASE("mine: mid-tunnel in the default mine, an alignment 4 m off along the roadway is never accepted", "[verify][mine][degeneracy]") {
  const Town mine = make_mine(1);
  const MineLayout layout = make_mine_layout(MineConfig{});
  const double length = layout.line_x[1] - layout.line_x[0];
  for (const LidarModel& model : {lidar_model_vlp16(), lidar_model_hdl64()}) {
    for (double f : {0.4, 0.5, 0.6}) {
      const MinePair p = make_pair(mine, model, 0, 0, 0, f * length - 2.0, f * length + 2.0);
      // The scans at identity: the same-looking tunnel, 4 m off the truth along the axis.
      const VerifyResult r = verify_from_guess(p.query, p.match, Eigen::Isometry3d::Identity(), VerifyConfig{});
      INFO(model.name << " at " << f << " of the roadway: " << describe(r, p));
      if (r.accepted) {
        CHECK(translation_error(r.T_match_query, p.T_match_query) < 0.2);  // only when GICP found the truth
      } else {
        CHECK(r.stage == VerifyStage::kDegeneracy);
      }
    }
  }
}

TEST_CASE("mine: a revisit 4 m apart at a junction is accepted with the right transform", "[verify][mine][degeneracy]") {
  const Town mine = make_mine(1);
  for (const LidarModel& model : {lidar_model_vlp16(), lidar_model_hdl64()}) {
    // Through junction (1, 1) (a crossing) eastwards, and into junction (1, 0) (a T) northwards.
    for (const auto& [i, j, dir] : {std::tuple{1, 1, 0}, std::tuple{1, 0, 1}}) {
      const MinePair p = make_pair(mine, model, i, j, dir, -2.0, 2.0);
      const VerifyResult r = verify(p.query, p.match, VerifyConfig{});
      INFO(model.name << " junction (" << i << ", " << j << "): " << describe(r, p));
      CHECK(r.accepted);
      CHECK_FALSE(r.degenerate);
      CHECK(translation_error(r.T_match_query, p.T_match_query) < 0.2);
      CHECK(rotation_error_deg(r.T_match_query, p.T_match_query) < 1.0);
    }
  }
}
