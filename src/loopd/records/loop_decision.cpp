#include "loopd/records/loop_decision.hpp"

namespace loopd {

std::string to_string(LoopStatus status) {
  switch (status) {
    case LoopStatus::kAccepted:
      return "accepted";
    case LoopStatus::kRejected:
      return "rejected";
    case LoopStatus::kCandidate:
      break;
  }
  return "candidate";
}

}  // namespace loopd
