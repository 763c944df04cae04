#include "loopd/pipeline/global_loops.hpp"

#include <cmath>

namespace loopd {

std::optional<std::string> GlobalRetrievalConfig::validate() const {
  if (auto e = descriptor.validate()) return "retrieval.descriptor: " + *e;
  if (auto e = retrieval.validate()) return "retrieval: " + *e;
  if (max_verified < 1) return "retrieval.max_verified must be >= 1";
  if (!(max_drift_fraction > 0.0 && max_drift_fraction <= 10.0)) return "retrieval.max_drift_fraction must be in (0, 10]";
  if (!(lateral_shift >= 0.0 && lateral_shift <= 50.0)) return "retrieval.lateral_shift must be in [0, 50] [m]";
  if (!(min_travel_gap >= 0.0 && std::isfinite(min_travel_gap))) return "retrieval.min_travel_gap must be a finite number >= 0 [m]";
  if (confirm_window < 1) return "retrieval.confirm_window must be >= 1";
  if (!(confirm_translation > 0.0 && std::isfinite(confirm_translation))) return "retrieval.confirm_translation must be > 0 [m]";
  if (!(confirm_rotation_deg > 0.0 && confirm_rotation_deg <= 180.0)) return "retrieval.confirm_rotation_deg must be in (0, 180]";
  return std::nullopt;
}

std::pair<double, double> PriorFreeConfirmation::disagreement(const PriorFreeLoop& a, const PriorFreeLoop& b) {
  const Eigen::Vector3d at = b.p_map_query;
  const double translation = (a.correction * at - b.correction * at).norm();
  const double rotation = Eigen::AngleAxisd(a.correction.linear().transpose() * b.correction.linear()).angle() * 180.0 / M_PI;
  return {translation, rotation};
}

std::optional<PriorFreeLoop> PriorFreeConfirmation::confirm(const PriorFreeLoop& loop) {
  if (held_ && held_->query.session == loop.query.session && held_->match_group == loop.match_group && loop.query.index > held_->query.index &&
      loop.query.index - held_->query.index <= config_.confirm_window) {
    const auto [translation, rotation] = disagreement(*held_, loop);
    if (translation <= config_.confirm_translation && rotation <= config_.confirm_rotation_deg) {
      PriorFreeLoop confirmed = *held_;
      held_.reset();
      return confirmed;
    }
  }
  held_ = loop;
  return std::nullopt;
}

}  // namespace loopd
