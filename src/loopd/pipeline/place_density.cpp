#include "loopd/pipeline/place_density.hpp"

#include <algorithm>
#include <cmath>

#include "loopd/base/angles.hpp"

namespace loopd {

std::optional<std::string> PlaceDensityConfig::validate() const {
  if (!(radius_per_spacing > 0.0 && std::isfinite(radius_per_spacing))) return "retirement.radius_per_spacing must be > 0";
  if (!(max_rotation_deg > 0.0 && max_rotation_deg <= 180.0)) return "retirement.max_rotation_deg must be in (0, 180]";
  if (keep < 1) return "retirement.keep must be >= 1";
  if (!(same_pass_radii >= 0.0 && std::isfinite(same_pass_radii))) return "retirement.same_pass_radii must be >= 0";
  return std::nullopt;
}

PlaceDensityResult thin_place(const PlaceKeyframe& newest, const std::vector<PlaceKeyframe>& near, double radius, const PlaceDensityConfig& config) {
  PlaceDensityResult out;
  const double max_rotation = config.max_rotation_deg * kRadPerDeg;
  std::vector<const PlaceKeyframe*> views;
  for (const PlaceKeyframe& k : near) {
    if (k.key == newest.key) continue;
    if (k.key.session == newest.key.session && std::abs(newest.travelled - k.travelled) < config.same_pass_radii * radius) continue;
    const Eigen::AngleAxisd turn(newest.T_map_sensor.linear().transpose() * k.T_map_sensor.linear());
    if (std::abs(turn.angle()) > max_rotation) continue;
    views.push_back(&k);
  }
  out.views = static_cast<int>(views.size());
  std::sort(views.begin(), views.end(), [](const PlaceKeyframe* a, const PlaceKeyframe* b) {
    if (a->retirable != b->retirable) return !a->retirable;
    if (a->loops != b->loops) return a->loops > b->loops;
    return b->key < a->key;
  });
  const auto kept_others = static_cast<std::size_t>(config.keep - 1);
  for (std::size_t i = kept_others; i < views.size(); ++i)
    if (views[i]->retirable) out.retire.push_back(views[i]->key);
  return out;
}

}  // namespace loopd
