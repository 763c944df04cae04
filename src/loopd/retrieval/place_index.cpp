// Scan Context retrieval (Kim & Kim, IROS 2018, Sec. III-C): ring-key k-NN, then the shift-minimised distance.
#include "loopd/retrieval/place_index.hpp"

#include <algorithm>
#include <limits>
#include <cmath>
#include <mutex>
#include <utility>

#include "loopd/base/stopwatch.hpp"

namespace loopd {

std::optional<std::string> RetrievalConfig::validate() const {
  if (k < 1) return "retrieval: k must be >= 1";
  if (ring_candidates < k) return "retrieval: ring_candidates must be >= k";
  if (!(max_place_distance >= 0.f) || !(max_place_distance <= 1.f)) return "retrieval: max_place_distance must be in [0, 1]";
  return std::nullopt;
}

bool PlaceIndex::compatible(const PlaceDescriptor& d) const {
  return d.num_rings == num_rings_ && d.num_sectors == num_sectors_ && d.max_range == max_range_ && d.height_offset == height_offset_ &&
         d.height_step == height_step_;
}

bool PlaceIndex::add(const KeyframeKey& key, PlaceDescriptor d) {
  const auto nr = static_cast<std::size_t>(d.num_rings), ns = static_cast<std::size_t>(d.num_sectors);
  if (!d.ok || nr == 0 || ns == 0 || d.bins.size() != nr * ns || d.column_norms.size() != ns || d.ring_key.size() != nr) return false;
  std::unique_lock lock(mutex_);
  if (keys_.empty()) {
    num_rings_ = d.num_rings;
    num_sectors_ = d.num_sectors;
    max_range_ = d.max_range;
    height_offset_ = d.height_offset;
    height_step_ = d.height_step;
  } else if (!compatible(d)) {
    return false;
  }
  slot_of_.emplace(key, keys_.size());
  keys_.push_back(key);
  ring_keys_.insert(ring_keys_.end(), d.ring_key.begin(), d.ring_key.end());
  bins_.insert(bins_.end(), d.bins.begin(), d.bins.end());
  column_norms_.insert(column_norms_.end(), d.column_norms.begin(), d.column_norms.end());
  return true;
}

bool PlaceIndex::remove(const KeyframeKey& key) {
  std::unique_lock lock(mutex_);
  const auto it = slot_of_.find(key);
  if (it == slot_of_.end()) return false;
  const std::size_t slot = it->second, last = keys_.size() - 1;
  slot_of_.erase(it);
  // Each array holds size() rows of one width: the last row moves into the freed one, then every array shrinks by a row.
  const auto move_last = [slot, last](auto& rows, std::size_t width) {
    if (slot != last)
      std::copy(rows.begin() + static_cast<std::ptrdiff_t>(last * width), rows.begin() + static_cast<std::ptrdiff_t>((last + 1) * width),
                rows.begin() + static_cast<std::ptrdiff_t>(slot * width));
    rows.resize(last * width);
  };
  const auto nr = static_cast<std::size_t>(num_rings_), ns = static_cast<std::size_t>(num_sectors_);
  move_last(ring_keys_, nr);
  move_last(bins_, nr * ns);
  move_last(column_norms_, ns);
  if (slot != last) {
    keys_[slot] = keys_[last];
    slot_of_[keys_[slot]] = slot;
  }
  keys_.pop_back();
  return true;
}

std::size_t PlaceIndex::size() const {
  std::shared_lock lock(mutex_);
  return keys_.size();
}

std::size_t PlaceIndex::bytes() const {
  std::shared_lock lock(mutex_);
  return keys_.capacity() * sizeof(KeyframeKey) + ring_keys_.capacity() * sizeof(float) + bins_.capacity() + column_norms_.capacity() * sizeof(float);
}

std::vector<PlaceCandidate> PlaceIndex::query(const PlaceDescriptor& q, const RetrievalConfig& config,
                                              const std::function<bool(const KeyframeKey&)>& accept, PlaceQueryStats* stats) const {
  return query_views({&q}, config, accept, stats);
}

bool PlaceIndex::usable(const PlaceDescriptor& q) const {
  const auto nr = static_cast<std::size_t>(num_rings_), ns = static_cast<std::size_t>(num_sectors_);
  return q.ok && compatible(q) && q.ring_key.size() == nr && q.bins.size() == nr * ns && q.column_norms.size() == ns;
}

std::vector<std::pair<float, std::size_t>> PlaceIndex::nearest_ring_keys(const std::vector<const PlaceDescriptor*>& views, std::size_t m,
                                                                         const std::function<bool(const KeyframeKey&)>& accept,
                                                                         std::size_t* accepted) const {
  // Exact ring-key k-NN over the accepted entries (Kim & Kim 2018 use a k-d tree; a flat scan is exact and as fast
  // here), each entry at its nearest view: the ring keys are read once however many views there are.
  const auto nr = static_cast<std::size_t>(num_rings_);
  std::vector<std::pair<float, std::size_t>> nearest;
  nearest.reserve(keys_.size());
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    if (accept && !accept(keys_[i])) continue;
    const float* key_i = ring_keys_.data() + i * nr;
    float best = std::numeric_limits<float>::max();
    for (const PlaceDescriptor* v : views) {
      const float* key_q = v->ring_key.data();
      float d2 = 0.f;
      for (std::size_t r = 0; r < nr; ++r) d2 += (key_i[r] - key_q[r]) * (key_i[r] - key_q[r]);
      best = std::min(best, d2);
    }
    nearest.emplace_back(best, i);
  }
  *accepted = nearest.size();
  m = std::min(nearest.size(), m);
  std::nth_element(nearest.begin(), nearest.begin() + static_cast<std::ptrdiff_t>(m), nearest.end());
  nearest.resize(m);
  return nearest;
}

std::vector<PlaceCandidate> PlaceIndex::query_views(const std::vector<const PlaceDescriptor*>& views, const RetrievalConfig& config,
                                                    const std::function<bool(const KeyframeKey&)>& accept, PlaceQueryStats* stats) const {
  Stopwatch watch;
  std::shared_lock lock(mutex_);
  const auto nr = static_cast<std::size_t>(num_rings_), ns = static_cast<std::size_t>(num_sectors_);
  if (config.validate() || views.empty() || keys_.empty()) return {};
  for (const PlaceDescriptor* v : views)
    if (!v || !usable(*v)) return {};
  std::size_t accepted = 0;
  const auto nearest = nearest_ring_keys(views, static_cast<std::size_t>(config.ring_candidates), accept, &accepted);
  const double ring_ms = watch.ms();

  std::vector<std::vector<float>> normalised(views.size(), std::vector<float>(nr * ns));
  for (std::size_t v = 0; v < views.size(); ++v) detail::normalised_columns(*views[v], normalised[v].data());
  std::vector<PlaceCandidate> out;
  out.reserve(nearest.size());
  for (const auto& [d2, i] : nearest) {
    PlaceMatch best;
    for (std::size_t v = 0; v < views.size(); ++v) {
      const PlaceMatch match =
          detail::place_distance_normalised(*views[v], normalised[v].data(), bins_.data() + i * nr * ns, column_norms_.data() + i * ns);
      if (v == 0 || match.distance < best.distance) best = match;
    }
    if (best.distance > config.max_place_distance) continue;
    out.push_back(PlaceCandidate{keys_[i], std::sqrt(d2), best.distance, best.yaw_match_query});
  }
  std::sort(out.begin(), out.end(), [](const PlaceCandidate& a, const PlaceCandidate& b) {
    return a.place_distance < b.place_distance || (a.place_distance == b.place_distance && a.key < b.key);
  });
  if (out.size() > static_cast<std::size_t>(config.k)) out.resize(static_cast<std::size_t>(config.k));
  if (stats) {
    stats->accepted = accepted;
    stats->compared = nearest.size();
    stats->ring_key_ms = ring_ms;
    stats->full_distance_ms = watch.ms() - ring_ms;
  }
  return out;
}

std::vector<PlaceCandidate> PlaceIndex::compare(const std::vector<const PlaceDescriptor*>& views, const std::vector<KeyframeKey>& keys,
                                                float max_place_distance) const {
  std::shared_lock lock(mutex_);
  const auto nr = static_cast<std::size_t>(num_rings_), ns = static_cast<std::size_t>(num_sectors_);
  std::vector<PlaceCandidate> out;
  if (views.empty() || keys_.empty()) return out;
  for (const PlaceDescriptor* v : views)
    if (!v || !usable(*v)) return out;
  std::vector<std::vector<float>> normalised(views.size(), std::vector<float>(nr * ns));
  for (std::size_t v = 0; v < views.size(); ++v) detail::normalised_columns(*views[v], normalised[v].data());
  for (const KeyframeKey& key : keys) {
    const auto it = slot_of_.find(key);
    if (it == slot_of_.end()) continue;
    const std::size_t i = it->second;
    PlaceMatch best;
    for (std::size_t v = 0; v < views.size(); ++v) {
      const PlaceMatch match =
          detail::place_distance_normalised(*views[v], normalised[v].data(), bins_.data() + i * nr * ns, column_norms_.data() + i * ns);
      if (v == 0 || match.distance < best.distance) best = match;
    }
    if (best.distance <= max_place_distance) out.push_back(PlaceCandidate{key, -1.f, best.distance, best.yaw_match_query});
  }
  return out;
}

}  // namespace loopd
