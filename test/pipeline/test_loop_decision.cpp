// From a verification to what the detector publishes (LoopDecision) and what it hands the correction (LoopConstraint):
// every field carried, the information kept in loopd's one (t, r) order.
#include <catch2/catch.hpp>

#include "loopd/base/information.hpp"
#include "loopd/pipeline/verification_decision.hpp"

using namespace loopd;

namespace {
VerifyResult accepted_verification() {
  VerifyResult v;
  v.accepted = true;
  v.stage = VerifyStage::kAccepted;
  v.reason = "flagged";
  v.T_match_query = Eigen::Translation3d(1.0, -2.0, 0.5) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ());
  v.lcp_fraction = 0.71;
  v.icp_residual = 0.18;
  v.icp_fitness = 0.93;
  v.hungarian_consistency = 0.62;
  v.degeneracy = 4.5;
  v.ms_fourpcs = 11.0;
  v.ms_gicp = 4.0;
  v.ms_hungarian = 0.5;
  v.ms_total = 16.0;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) v.information(r, c) = 10.0 * r + c;
  return v;
}
}  // namespace

TEST_CASE("an accepted verification becomes an accepted decision with every score and the descriptor time") {
  const VerifyResult v = accepted_verification();
  LoopDecision d;
  d.descriptor_distance = 0.2;
  apply_verification(v, 3.0, d);
  CHECK(d.status == LoopStatus::kAccepted);
  CHECK(d.stage == "accepted");
  CHECK(d.reason == "flagged");
  CHECK(d.lcp_fraction == 0.71);
  CHECK(d.icp_residual == 0.18);
  CHECK(d.icp_fitness == 0.93);
  CHECK(d.hungarian_consistency == 0.62);
  CHECK(d.degeneracy == 4.5);
  CHECK(d.T_match_query.isApprox(v.T_match_query, 0.0));
  CHECK(d.information == v.information);  // kept so a map store can rebuild the loop edge
  CHECK(d.ms_descriptor == 3.0);
  CHECK(d.ms_fourpcs == 11.0);
  CHECK(d.ms_total == 19.0);
  CHECK(d.descriptor_distance == 0.2);  // the ranking's score is not the verification's to change
}

TEST_CASE("a rejected verification names the stage that rejected") {
  VerifyResult v;
  v.accepted = false;
  v.stage = VerifyStage::kHungarian;
  v.reason = "too few clusters matched";
  LoopDecision d;
  apply_verification(v, 1.0, d);
  CHECK(d.status == LoopStatus::kRejected);
  CHECK(d.stage == "hungarian");
  CHECK(d.reason == "too few clusters matched");
}

TEST_CASE("the loop constraint carries the positions, the transform and the information unchanged") {
  const VerifyResult v = accepted_verification();
  const LoopConstraint loop = to_loop_constraint(v, 812, 17);
  CHECK(loop.query_index == 812);
  CHECK(loop.match_index == 17);
  CHECK(loop.T_match_query.isApprox(v.T_match_query, 0.0));
  CHECK(loop.information == v.information);
}

TEST_CASE("GICP's rotation-first Hessian is reordered into loopd's translation-first information") {
  Eigen::Matrix<double, 6, 6> rt;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) rt(r, c) = 10.0 * r + c;
  const Information6d tr = information_from_rotation_first(rt);
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) CHECK(tr(r, c) == rt((r + 3) % 6, (c + 3) % 6));
  CHECK(information_from_rotation_first(tr) == rt);  // the swap is its own inverse
}
