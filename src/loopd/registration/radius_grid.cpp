#include "loopd/registration/radius_grid.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace loopd {
namespace {

constexpr int kBits = 21;  // per axis in a cell key; cells farther apart than 2^21 share keys (harmless: distances decide)
constexpr std::int64_t kMask = (std::int64_t{1} << kBits) - 1;

std::int64_t cell_index(float v) {
  const float c = std::floor(v);
  return static_cast<std::int64_t>(std::max(-1e9f, std::min(1e9f, c)));  // NaN-free input; the clamp keeps the cast defined
}

// Fibonacci hashing: the product's top bits depend on every bit of the key (its low bits only on the key's low bits).
std::size_t slot_of(std::int64_t key, int table_bits) {
  return static_cast<std::size_t>((static_cast<std::uint64_t>(key) * 0x9E3779B97F4A7C15ull) >> (64 - table_bits));
}

}  // namespace

std::int64_t RadiusGrid::cell_of(float x, float y, float z) const {
  return ((cell_index(x * inv_cell_) & kMask) << (2 * kBits)) | ((cell_index(y * inv_cell_) & kMask) << kBits) | (cell_index(z * inv_cell_) & kMask);
}

RadiusGrid::RadiusGrid(const std::vector<Eigen::Vector3f>& points, float radius)
    : points_(points), radius_sq_(radius * radius), inv_cell_(1.f / radius) {
  std::vector<std::pair<std::int64_t, int>> keyed(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) keyed[i] = {cell_of(points[i].x(), points[i].y(), points[i].z()), static_cast<int>(i)};
  std::sort(keyed.begin(), keyed.end());
  order_.resize(keyed.size());
  for (std::size_t i = 0; i < keyed.size(); ++i) {
    order_[i] = keyed[i].second;
    if (cells_.empty() || cells_.back().key != keyed[i].first) cells_.push_back({keyed[i].first, static_cast<int>(i), static_cast<int>(i)});
    ++cells_.back().end;
  }
  table_bits_ = 4;
  while ((std::size_t{1} << table_bits_) < 2 * cells_.size()) ++table_bits_;
  const std::size_t size = std::size_t{1} << table_bits_;
  slots_.assign(size, -1);
  for (std::size_t c = 0; c < cells_.size(); ++c) {
    std::size_t s = slot_of(cells_[c].key, table_bits_);
    while (slots_[s] >= 0) s = (s + 1) & (size - 1);
    slots_[s] = static_cast<int>(c);
  }
}

const RadiusGrid::Cell* RadiusGrid::find(std::int64_t key) const {
  const std::size_t mask = slots_.size() - 1;
  for (std::size_t s = slot_of(key, table_bits_);; s = (s + 1) & mask) {
    const int c = slots_[s];
    if (c < 0) return nullptr;
    if (cells_[static_cast<std::size_t>(c)].key == key) return &cells_[static_cast<std::size_t>(c)];
  }
}

void RadiusGrid::within(const Eigen::Vector3f& q, std::vector<int>* out) const {
  if (cells_.empty()) return;
  const float r = 1.001f / inv_cell_;  // a little wider than the radius: rounding never drops a cell
  // The cells of the ball's bounding box: two per axis (a cell is as wide as the radius), one where both ends share it.
  const std::int64_t x0 = cell_index((q.x() - r) * inv_cell_), x1 = cell_index((q.x() + r) * inv_cell_);
  const std::int64_t y0 = cell_index((q.y() - r) * inv_cell_), y1 = cell_index((q.y() + r) * inv_cell_);
  const std::int64_t z0 = cell_index((q.z() - r) * inv_cell_), z1 = cell_index((q.z() + r) * inv_cell_);
  for (std::int64_t x = x0; x <= x1; ++x)
    for (std::int64_t y = y0; y <= y1; ++y)
      for (std::int64_t z = z0; z <= z1; ++z) {
        const Cell* cell = find(((x & kMask) << (2 * kBits)) | ((y & kMask) << kBits) | (z & kMask));
        if (cell == nullptr) continue;
        for (int k = cell->begin; k < cell->end; ++k) {
          const int i = order_[static_cast<std::size_t>(k)];
          const Eigen::Vector3f& p = points_[static_cast<std::size_t>(i)];
          float d = 0.f;  // the k-d tree's order of summation
          const float dx = q.x() - p.x(), dy = q.y() - p.y(), dz = q.z() - p.z();
          d += dx * dx;
          d += dy * dy;
          d += dz * dz;
          if (d < radius_sq_) out->push_back(i);
        }
      }
}

}  // namespace loopd
