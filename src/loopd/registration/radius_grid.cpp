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

}  // namespace

std::uint64_t RadiusGrid::cell_of(float x, float y, float z) const {
  return static_cast<std::uint64_t>(((cell_index(x * inv_cell_) & kMask) << (2 * kBits)) | ((cell_index(y * inv_cell_) & kMask) << kBits) |
                                    (cell_index(z * inv_cell_) & kMask));
}

RadiusGrid::RadiusGrid(const std::vector<Eigen::Vector3f>& points, float radius)
    : points_(points), radius_sq_(radius * radius), inv_cell_(1.f / radius), table_(2 * points.size()) {
  std::vector<std::pair<std::uint64_t, int>> keyed(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) keyed[i] = {cell_of(points[i].x(), points[i].y(), points[i].z()), static_cast<int>(i)};
  std::sort(keyed.begin(), keyed.end());
  order_.resize(keyed.size());
  for (std::size_t i = 0; i < keyed.size(); ++i) {
    order_[i] = keyed[i].second;
    bool new_cell = false;
    table_.find_or_insert(keyed[i].first, &new_cell);  // cells are met in key order: a new key is cells_.size()
    if (new_cell) cells_.push_back({static_cast<int>(i), static_cast<int>(i)});
    ++cells_.back().end;
  }
}

const RadiusGrid::Cell* RadiusGrid::find(std::uint64_t key) const {
  const std::int64_t c = table_.find(key);
  return c < 0 ? nullptr : &cells_[static_cast<std::size_t>(c)];
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
        const Cell* cell = find(static_cast<std::uint64_t>(((x & kMask) << (2 * kBits)) | ((y & kMask) << kBits) | (z & kMask)));
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
