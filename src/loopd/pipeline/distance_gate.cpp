#include "loopd/pipeline/distance_gate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace loopd {

namespace {

/// @brief Hash key of ground-plane cell (ix, iy): ix in the high 32 bits, the low 32 bits of iy xor-ed in. Shifted as
/// unsigned (a left shift of a negative signed value is undefined before C++20; UBSan reported it for cells at x < 0);
/// the same bits as the signed (ix << 32) ^ (iy & 0xffffffff) for every ix >= 0.
std::int64_t cell_key(std::int64_t ix, std::int64_t iy) {
  const std::uint64_t bits = (static_cast<std::uint64_t>(ix) << 32) ^ (static_cast<std::uint64_t>(iy) & 0xffffffffULL);
  return static_cast<std::int64_t>(bits);
}

void sort_nearest_first(std::vector<GateCandidate>& candidates) {
  std::sort(candidates.begin(), candidates.end(),
            [](const GateCandidate& a, const GateCandidate& b) { return a.distance < b.distance || (a.distance == b.distance && a.key < b.key); });
}

}  // namespace

std::optional<std::string> DistanceGateConfig::validate() const {
  if (!(travel_fraction > 0.0)) return "gate.travel_fraction must be > 0";
  if (!(min_radius >= 1e-3)) return "gate.min_radius must be >= 0.001 [m]";  // cells of max_radius stay in int64 range
  if (!(max_radius >= min_radius)) return "gate.max_radius must be >= gate.min_radius";
  if (min_index_gap < 1) return "gate.min_index_gap must be >= 1";
  if (!(min_travel_gap >= 0.0)) return "gate.min_travel_gap must be >= 0";
  if (!(travel_gap_per_scale >= 0.0 && std::isfinite(travel_gap_per_scale))) return "gate.travel_gap_per_scale must be >= 0";
  if (!(min_travel_gap_floor >= 0.0 && std::isfinite(min_travel_gap_floor))) return "gate.min_travel_gap_floor must be >= 0 [m]";
  if (!(travel_gap_per_radius >= 0.0 && std::isfinite(travel_gap_per_radius))) return "gate.travel_gap_per_radius must be >= 0";
  return std::nullopt;
}

double DistanceGate::radius(double travelled_since_loop) const {
  return std::clamp(config_.travel_fraction * travelled_since_loop, config_.min_radius, config_.max_radius);
}

double DistanceGate::travel_gap(double scene_scale, double radius) const {
  if (!(config_.travel_gap_per_scale > 0.0 && scene_scale > 0.0)) return config_.min_travel_gap;
  const double scaled = std::max({config_.min_travel_gap_floor, config_.travel_gap_per_scale * scene_scale, config_.travel_gap_per_radius * radius});
  return std::min(config_.min_travel_gap, scaled);
}

DistanceGate::CellKey DistanceGate::key(const Eigen::Vector3d& p) const {
  // Cells in the ground plane, one max_radius wide: a query touches at most 3x3 cells.
  const double cell = config_.max_radius;
  const std::int64_t ix = static_cast<std::int64_t>(std::floor(p.x() / cell));
  const std::int64_t iy = static_cast<std::int64_t>(std::floor(p.y() / cell));
  return cell_key(ix, iy);
}

template <typename Visit>
void DistanceGate::for_each_near(const Eigen::Vector3d& position, Visit&& visit) const {
  // The 3 x 3 cells of max_radius around the position hold every entry within max_radius of it.
  const double cell = config_.max_radius;
  const auto cx = static_cast<std::int64_t>(std::floor(position.x() / cell));
  const auto cy = static_cast<std::int64_t>(std::floor(position.y() / cell));
  for (std::int64_t dx = -1; dx <= 1; ++dx) {
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      const auto it = cells_.find(cell_key(cx + dx, cy + dy));
      if (it == cells_.end()) continue;
      for (std::size_t i : it->second) visit(entries_[i]);
    }
  }
}

void DistanceGate::add(const GateEntry& entry) {
  cells_[key(entry.position)].push_back(entries_.size());
  entries_.push_back(entry);
}

void DistanceGate::update_positions(const std::function<Eigen::Vector3d(const KeyframeKey&)>& position_of) {
  for (GateEntry& e : entries_) e.position = position_of(e.key);
  rebuild();
}

void DistanceGate::update_positions_from(std::size_t first, const std::function<Eigen::Vector3d(std::size_t entry)>& position_of) {
  for (std::size_t i = first; i < entries_.size(); ++i) {
    GateEntry& e = entries_[i];
    const Eigen::Vector3d p = position_of(i);
    const CellKey before = key(e.position), after = key(p);
    e.position = p;
    if (before == after || e.retired) continue;
    // Each cell lists its entries in the order added, as rebuild() leaves it (candidates() keeps that order for ties).
    std::vector<std::size_t>& from = cells_[before];
    const auto it = std::lower_bound(from.begin(), from.end(), i);
    if (it != from.end() && *it == i) from.erase(it);
    std::vector<std::size_t>& to = cells_[after];
    to.insert(std::lower_bound(to.begin(), to.end(), i), i);
  }
}

void DistanceGate::rebuild() {
  cells_.clear();
  for (std::size_t i = 0; i < entries_.size(); ++i)
    if (!entries_[i].retired) cells_[key(entries_[i].position)].push_back(i);
}

bool DistanceGate::retire(std::size_t entry) {
  if (entry >= entries_.size() || entries_[entry].retired) return false;
  entries_[entry].retired = true;
  const auto it = cells_.find(key(entries_[entry].position));
  if (it != cells_.end()) {
    std::vector<std::size_t>& cell = it->second;
    const auto at = std::lower_bound(cell.begin(), cell.end(), entry);
    if (at != cell.end() && *at == entry) cell.erase(at);
    if (cell.empty()) cells_.erase(it);
  }
  return true;
}

std::vector<GateCandidate> DistanceGate::within(const Eigen::Vector3d& position, double radius) const {
  std::vector<GateCandidate> out;
  for_each_near(position, [&](const GateEntry& e) {
    const double d = (e.position - position).norm();
    if (d <= radius) out.push_back({e.key, d});
  });
  sort_nearest_first(out);
  return out;
}

std::vector<GateCandidate> DistanceGate::candidates(const GateEntry& query, double radius, const std::function<bool(const KeyframeKey&)>& accept,
                                                    double travel_gap) const {
  std::vector<GateCandidate> out;
  const double min_travel = travel_gap >= 0.0 ? travel_gap : config_.min_travel_gap;
  // A scaled-down travel gap scales the index gap with it (keyframes lie closer together in a small scene too).
  const int min_index_gap =
      min_travel < config_.min_travel_gap && config_.min_travel_gap > 0.0
          ? std::max(std::min(config_.min_index_gap, 5), static_cast<int>(std::lround(config_.min_index_gap * min_travel / config_.min_travel_gap)))
          : config_.min_index_gap;
  for_each_near(query.position, [&](const GateEntry& e) {
    const bool same_session = e.key.session == query.key.session;
    if (same_session && keyframes_between(e.key, query.key) < min_index_gap) return;
    if (same_session && query.travelled - e.travelled < min_travel) return;
    const double d = (e.position - query.position).norm();
    if (d <= radius && (!accept || accept(e.key))) out.push_back({e.key, d});
  });
  sort_nearest_first(out);
  return out;
}

}  // namespace loopd
