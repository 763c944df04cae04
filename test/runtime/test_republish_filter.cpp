// RepublishFilter and LoopDetector::expect_decisions: after a restart, a candidate of the keyframe a stop cut off takes
// the id it had; one that reached the bus before the stop and is decided the same stays off it, a different one is
// published.
#include <catch2/catch.hpp>

#include <vector>

#include "loopd/runtime/republish_filter.hpp"

using namespace loopd;

namespace {

struct Recorder : EngineSink {
  std::vector<LoopDecision> decisions;
  int corrections = 0;
  void on_decision(const LoopDecision& d) override { decisions.push_back(d); }
  void on_correction(const CorrectionOutput&) override { ++corrections; }
};

LoopDecision decision(std::int64_t event, std::int64_t match, LoopStatus status) {
  LoopDecision d;
  d.event_id = event;
  d.query = KeyframeKey{0, 40};
  d.query_utime = 4000000;
  d.match = KeyframeKey{0, match};
  d.status = status;
  d.T_match_query.translation() = Eigen::Vector3d(0.5, -0.25, 0.0);
  return d;
}

}  // namespace

TEST_CASE("republish filter: decisions published before the stop are not published again, changed and unpublished ones are") {
  Recorder bus;
  RepublishFilter filter(bus);
  // Cut off by the stop and published: 5, 6, 7 (8 was committed, the stop came before the bus had it).
  filter.expect({decision(5, 1, LoopStatus::kRejected), decision(6, 2, LoopStatus::kAccepted), decision(7, 3, LoopStatus::kRejected)});
  filter.on_decision(decision(5, 1, LoopStatus::kRejected));  // the same: already on the bus
  LoopDecision moved = decision(6, 2, LoopStatus::kAccepted);
  moved.T_match_query.translation().x() += 0.1;
  filter.on_decision(moved);                                  // decided otherwise: published, replaces the earlier
  filter.on_decision(decision(7, 3, LoopStatus::kAccepted));  // another status: published
  filter.on_decision(decision(8, 9, LoopStatus::kAccepted));  // never published: published now
  filter.on_decision(decision(9, 4, LoopStatus::kRejected));  // new
  filter.on_decision(decision(5, 1, LoopStatus::kRejected));  // expected once only: a second one passes
  filter.on_correction(CorrectionOutput{});
  REQUIRE(bus.decisions.size() == 5);
  CHECK(bus.decisions[0].event_id == 6);
  CHECK(bus.decisions[1].event_id == 7);
  CHECK(bus.decisions[2].event_id == 8);
  CHECK(bus.decisions[3].event_id == 9);
  CHECK(bus.decisions[4].event_id == 5);
  CHECK(filter.not_republished() == 1);
  CHECK(bus.corrections == 1);
}

TEST_CASE("republish filter: nothing cut off, everything passes") {
  Recorder bus;
  RepublishFilter filter(bus);
  filter.expect({});
  for (std::int64_t i = 0; i < 4; ++i) filter.on_decision(decision(i, i, LoopStatus::kRejected));
  CHECK(bus.decisions.size() == 4);
  CHECK(filter.not_republished() == 0);
}
