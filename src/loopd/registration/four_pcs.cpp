#include "loopd/registration/four_pcs.hpp"

namespace loopd {

std::optional<std::string> FourPcsConfig::validate() const {
  if (delta <= 0) return "delta must be > 0";
  if (max_bases < 1) return "max_bases must be >= 1";
  if (num_threads < 1) return "num_threads must be >= 1";
  return std::nullopt;
}

FourPcsResult align_four_pcs(const std::vector<Eigen::Vector3f>&, const Segmentation&, const std::vector<Eigen::Vector3f>&,
                             const Segmentation&, const FourPcsConfig&) {
  FourPcsResult r;
  r.reason = "not implemented yet";
  return r;
}

}  // namespace loopd
