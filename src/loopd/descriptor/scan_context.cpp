// Scan Context (Kim & Kim, IROS 2018): polar max-height bins, ring key, shift-minimised column cosine distance.
#include "loopd/descriptor/scan_context.hpp"

#include "loopd/base/fast_atan2.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include "loopd/base/angles.hpp"

namespace loopd {

namespace {
constexpr int kMaxBinsPerAxis = 1024;  ///< bounds a config's size (a decoded one too): at most 1M bins
constexpr float kMaxQuantised = 255.f;

/// Yaw of shift k (plus a fractional refinement) wrapped to (-pi, pi].
double shift_to_yaw(double shift, int num_sectors) {
  double yaw = shift * 2.0 * kPi / num_sectors;
  while (yaw > kPi) yaw -= 2.0 * kPi;
  while (yaw <= -kPi) yaw += 2.0 * kPi;
  return yaw;
}
}  // namespace

std::optional<std::string> ScanContextConfig::validate() const {
  if (num_rings < 1 || num_rings > kMaxBinsPerAxis) return "scan context: num_rings must be in 1.." + std::to_string(kMaxBinsPerAxis);
  if (num_sectors < 3 || num_sectors > kMaxBinsPerAxis) return "scan context: num_sectors must be in 3.." + std::to_string(kMaxBinsPerAxis);
  if (!(max_range > 0.f) || !std::isfinite(max_range)) return "scan context: max_range must be finite and > 0";
  if (!std::isfinite(height_offset)) return "scan context: height_offset must be finite";
  if (!(height_step > 0.f) || !std::isfinite(height_step)) return "scan context: height_step must be finite and > 0";
  if (min_points < 1) return "scan context: min_points must be >= 1";
  return std::nullopt;
}

namespace detail {

void finish_place_descriptor(PlaceDescriptor& d) {
  const auto nr = static_cast<std::size_t>(d.num_rings), ns = static_cast<std::size_t>(d.num_sectors);
  d.column_norms.assign(ns, 0.f);
  d.ring_key.assign(nr, 0.f);
  for (std::size_t s = 0; s < ns; ++s) {
    std::uint32_t sum2 = 0;
    for (std::size_t r = 0; r < nr; ++r) {
      const std::uint32_t v = d.bins[s * nr + r];
      sum2 += v * v;
      if (v > 0) d.ring_key[r] += 1.f;
    }
    d.column_norms[s] = std::sqrt(static_cast<float>(sum2));
  }
  for (float& k : d.ring_key) k /= static_cast<float>(ns);  // Kim & Kim 2018: psi(r_i) = ||r_i||_0 / N_s
}

void normalised_columns(const PlaceDescriptor& d, float* out) {
  const auto nr = static_cast<std::size_t>(d.num_rings), ns = static_cast<std::size_t>(d.num_sectors);
  for (std::size_t s = 0; s < ns; ++s) {
    const float inv = d.column_norms[s] > 0.f ? 1.f / d.column_norms[s] : 0.f;
    for (std::size_t r = 0; r < nr; ++r) out[s * nr + r] = static_cast<float>(d.bins[s * nr + r]) * inv;
  }
}

PlaceMatch place_distance_normalised(const PlaceDescriptor& query, const float* query_normalised, const std::uint8_t* match_bins,
                                     const float* match_norms) {
  const int nr = query.num_rings, ns = query.num_sectors;
  // Match columns to unit length, then every query-match column cosine at once: M(i, j) = cos(c_q^i, c_m^j).
  Eigen::MatrixXf mn(nr, ns);
  for (int s = 0; s < ns; ++s) {
    const float inv = match_norms[s] > 0.f ? 1.f / match_norms[s] : 0.f;
    for (int r = 0; r < nr; ++r) mn(r, s) = static_cast<float>(match_bins[s * nr + r]) * inv;
  }
  const Eigen::Map<const Eigen::MatrixXf> qn(query_normalised, nr, ns);
  const Eigen::MatrixXf cosines = qn.transpose() * mn;
  // Kim & Kim 2018, Eq. (6): for each shift k, the mean column distance over the columns not empty in both.
  std::vector<double> dist(static_cast<std::size_t>(ns), 1.0);
  for (int k = 0; k < ns; ++k) {
    double sim = 0;
    int counted = 0;
    for (int i = 0; i < ns; ++i) {
      const int j = (i + k) % ns;
      if (query.column_norms[static_cast<std::size_t>(i)] == 0.f && match_norms[j] == 0.f) continue;
      ++counted;
      sim += cosines(i, j);
    }
    if (counted > 0) dist[static_cast<std::size_t>(k)] = std::clamp(1.0 - sim / counted, 0.0, 1.0);
  }
  const int best = static_cast<int>(std::min_element(dist.begin(), dist.end()) - dist.begin());
  // Sub-sector yaw: vertex of the parabola through the best shift and its neighbours, within half a sector.
  const double a = dist[static_cast<std::size_t>((best + ns - 1) % ns)], b = dist[static_cast<std::size_t>(best)],
               c = dist[static_cast<std::size_t>((best + 1) % ns)];
  const double curvature = a - 2.0 * b + c;
  const double offset = curvature > 1e-12 ? std::clamp(0.5 * (a - c) / curvature, -0.5, 0.5) : 0.0;
  PlaceMatch m;
  m.ok = true;
  m.shift = best;
  m.distance = static_cast<float>(b);
  // Query column s (azimuth theta) matches match column s + k (azimuth theta + k * 2 pi / N_s): the match frame sees
  // the query's points turned by +k sectors, p_match = Rz(k * 2 pi / N_s) p_query.
  m.yaw_match_query = shift_to_yaw(best + offset, ns);
  return m;
}

}  // namespace detail

PlaceDescriptor compute_place_descriptor(const PointCloud& cloud, const ScanContextConfig& config) {
  return compute_place_descriptor(cloud, config, Eigen::Vector2f::Zero());
}

namespace {

/// The sector (before the clamp to the last) of azimuth atan2(y, x) + pi, exactly as std::atan2 bins it: fast_atan2
/// (error <= 2.1e-4 rad) decides, except within 5e-4 rad of a sector boundary (1 % of the points at 60 sectors), where
/// std::atan2 does. Bins and decisions are therefore those of std::atan2 alone, at a fraction of its cost.
std::size_t sector_of(float x, float y, float sectors_per_rad) {
  const float t = (fast_atan2(y, x) + static_cast<float>(kPi)) * sectors_per_rad;
  if (std::abs(t - std::round(t)) > 5e-4f * sectors_per_rad) return static_cast<std::size_t>(std::max(0.f, t));
  const float azimuth = std::atan2(y, x) + static_cast<float>(kPi);  // [0, 2 pi]
  return static_cast<std::size_t>(azimuth * sectors_per_rad);
}

}  // namespace

PlaceDescriptor compute_place_descriptor(const PointCloud& cloud, const ScanContextConfig& config, const Eigen::Vector2f& origin) {
  PlaceDescriptor d;
  if (const auto err = config.validate()) {
    d.error = *err;
    return d;
  }
  d.num_rings = config.num_rings;
  d.num_sectors = config.num_sectors;
  d.max_range = config.max_range;
  d.height_offset = config.height_offset;
  d.height_step = config.height_step;
  const auto nr = static_cast<std::size_t>(config.num_rings), ns = static_cast<std::size_t>(config.num_sectors);
  std::vector<float> highest(nr * ns, -std::numeric_limits<float>::infinity());
  // Single precision: a scan's coordinates are float, and a bin is 4 m x 6 deg (HDL-64E: 3x faster than double hypot).
  const float rings_per_m = static_cast<float>(config.num_rings) / config.max_range;
  const float sectors_per_rad = static_cast<float>(config.num_sectors / (2.0 * kPi));
  const float max_range2 = config.max_range * config.max_range;
  int used = 0;
  for (const Eigen::Vector3f& p : cloud.points) {
    if (!p.allFinite()) continue;
    const float x = p.x() - origin.x(), y = p.y() - origin.y();
    const float range2 = x * x + y * y;
    if (range2 >= max_range2) continue;
    const auto r = std::min(nr - 1, static_cast<std::size_t>(std::sqrt(range2) * rings_per_m));
    const auto s = std::min(ns - 1, sector_of(x, y, sectors_per_rad));
    float& h = highest[s * nr + r];
    h = std::max(h, p.z() + config.height_offset);
    ++used;
  }
  d.num_points = used;
  if (used < config.min_points) {
    d.error = "scan context: " + std::to_string(used) + " usable points (finite, within " + std::to_string(config.max_range) + " m), fewer than " +
              std::to_string(config.min_points);
    return d;
  }
  d.bins.resize(nr * ns);
  for (std::size_t i = 0; i < highest.size(); ++i) {
    const float q = std::round(std::max(0.f, highest[i]) / config.height_step);  // empty bin: -inf -> 0
    d.bins[i] = static_cast<std::uint8_t>(std::min(kMaxQuantised, q));
  }
  detail::finish_place_descriptor(d);
  d.ok = true;
  return d;
}

PlaceMatch place_distance(const PlaceDescriptor& query, const PlaceDescriptor& match) {
  const auto expected = static_cast<std::size_t>(query.num_rings) * static_cast<std::size_t>(query.num_sectors);
  const bool usable = query.ok && match.ok && query.num_rings == match.num_rings && query.num_sectors == match.num_sectors && expected > 0 &&
                      query.bins.size() == expected && match.bins.size() == expected &&
                      query.column_norms.size() == static_cast<std::size_t>(query.num_sectors) &&
                      match.column_norms.size() == static_cast<std::size_t>(match.num_sectors);
  if (!usable) return PlaceMatch{};
  std::vector<float> qn(expected);
  detail::normalised_columns(query, qn.data());
  return detail::place_distance_normalised(query, qn.data(), match.bins.data(), match.column_norms.data());
}

}  // namespace loopd
