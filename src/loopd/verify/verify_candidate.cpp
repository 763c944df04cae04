#include "loopd/verify/verify.hpp"

namespace loopd {

VerifyResult verify_candidate(const PreparedScan& query, const PreparedScan& match, const std::optional<Eigen::Isometry3d>& guess_T_match_query,
                              const VerifyConfig& config) {
  VerifyResult v;
  if (guess_T_match_query) {
    // The corrected map is locally consistent right after a loop: its relative pose seeds GICP.
    v = verify_from_guess(query, match, *guess_T_match_query, config);
    if (v.accepted) {
      v.reason = "guided: GICP from the corrected map's relative pose (4PCS skipped)" + (v.reason.empty() ? std::string() : "; " + v.reason);
      return v;
    }
  }
  const double guided_ms = guess_T_match_query ? v.ms_total : 0.0;
  v = verify(query, match, config);
  v.ms_total += guided_ms;
  return v;
}

}  // namespace loopd
