// The one conversion of a loop decision to its message and back: every field that travels comes back bit for bit
// (the rotation within 1e-15: it is re-orthonormalised on the way in) through the wire (encode, bounded decode), the ones that do not travel come
// back as documented, and a message with a status that is none of STATUS_* is refused with a reason instead of becoming a decision.
#include <catch2/catch.hpp>
#include <cstring>
#include <vector>

#include "bounded_decode.hpp"
#include "loop_event_convert.hpp"

using namespace loopd;

namespace {

loop_event_t through_wire(const loop_event_t& m) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  REQUIRE(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())) == static_cast<int>(bytes.size()));
  loop_event_t out;
  REQUIRE(decode_any_loop_event(bytes.data(), bytes.size(), DecodeLimits{}, &out).ok);
  return out;
}

LoopDecision awkward_decision() {
  LoopDecision d;
  d.event_id = 1234567890123;
  d.query = KeyframeKey{2000001, 4000000001};
  d.match = KeyframeKey{7, 3};
  d.query_utime = 1700000000123456;
  d.match_utime = 1700000000000001;
  d.status = LoopStatus::kRejected;
  d.stage = "hungarian";
  d.reason = "consistency 0.31 < 0.5";
  d.gate_distance = 12.25;
  d.gate_radius = 1.0 / 3.0;
  d.descriptor_distance = 0.1 + 0.2;
  d.lcp_fraction = 0.7071067811865476;
  d.icp_residual = 1e-7;
  d.icp_fitness = 0.999;
  d.hungarian_consistency = 0.31;
  d.degeneracy = 3.5e-4;
  d.retrieval = "global";
  d.place_distance = 0.1234;
  d.T_match_query.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, -0.4, 0.9).normalized()).toRotationMatrix();
  d.T_match_query.translation() = Eigen::Vector3d(1.0 / 7.0, -2.5, 0.001);
  d.ms_descriptor = 1.5;
  d.ms_fourpcs = 20.25;
  d.ms_gicp = 3.125;
  d.ms_hungarian = 0.5;
  d.ms_total = 25.375;
  d.information = Information6d::Identity() * 42.0;  // does not travel
  d.confirmed = true;                                // does not travel
  d.published = false;                               // does not travel
  return d;
}

}  // namespace

TEST_CASE("loop event: a decision goes out and comes back with every field that travels, bit for bit") {
  const LoopDecision d = awkward_decision();
  const loop_event_t m = through_wire(to_message(d, 99));
  CHECK(m.utime == 99);
  LoopDecision back;
  std::string why;
  REQUIRE(from_message(m, &back, &why));
  CHECK(back.event_id == d.event_id);
  CHECK(back.query == d.query);
  CHECK(back.match == d.match);
  CHECK(back.query_utime == d.query_utime);
  CHECK(back.match_utime == d.match_utime);
  CHECK(back.status == d.status);
  CHECK(back.stage == d.stage);
  CHECK(back.reason == d.reason);
  for (const auto field : {&LoopDecision::gate_distance, &LoopDecision::gate_radius, &LoopDecision::descriptor_distance, &LoopDecision::lcp_fraction,
                           &LoopDecision::icp_residual, &LoopDecision::icp_fitness, &LoopDecision::hungarian_consistency, &LoopDecision::degeneracy,
                           &LoopDecision::place_distance, &LoopDecision::ms_descriptor, &LoopDecision::ms_fourpcs, &LoopDecision::ms_gicp,
                           &LoopDecision::ms_hungarian, &LoopDecision::ms_total})
    CHECK(back.*field == d.*field);
  CHECK(back.retrieval == d.retrieval);
  // The translation exactly; the rotation re-orthonormalised on the way in (from_row_major), so within 1e-15.
  CHECK(std::memcmp(back.T_match_query.translation().data(), d.T_match_query.translation().data(), 3 * sizeof(double)) == 0);
  CHECK((back.T_match_query.linear() - d.T_match_query.linear()).cwiseAbs().maxCoeff() < 1e-15);
  // What does not travel comes back as the message documents it.
  CHECK(back.information.isZero());
  CHECK_FALSE(back.confirmed);
  CHECK(back.published);
}

TEST_CASE("loop event: a status that is none of STATUS_* is refused, naming the event and the status") {
  for (const std::int8_t status : {std::int8_t{3}, std::int8_t{-1}, std::int8_t{127}}) {
    loop_event_t m = to_message(awkward_decision(), 1);
    m.status = status;
    LoopDecision back;
    std::string why;
    CHECK_FALSE(from_message(through_wire(m), &back, &why));
    CHECK_THAT(why, Catch::Contains("loop event 1234567890123") && Catch::Contains("unknown status " + std::to_string(int{status})));
  }
  for (const LoopStatus status : {LoopStatus::kCandidate, LoopStatus::kAccepted, LoopStatus::kRejected}) {
    LoopDecision d = awkward_decision();
    d.status = status;
    LoopDecision back;
    std::string why;
    REQUIRE(from_message(through_wire(to_message(d, 1)), &back, &why));
    CHECK(back.status == status);
    CHECK(to_string(status) == (status == LoopStatus::kAccepted ? "accepted" : status == LoopStatus::kRejected ? "rejected" : "candidate"));
  }
}
