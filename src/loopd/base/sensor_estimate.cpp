#include "loopd/base/sensor_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <vector>

#include "loopd/base/fast_atan2.hpp"

namespace loopd {
namespace {

constexpr double kRadToDeg = 57.295779513082320876;
constexpr int kAzimuthBins = 360;

/// Elevations [deg] of a deterministic sample of the returns, azimuth coverage, and the number of returns.
struct ElevationSample {
  std::vector<float> all, far;   // every sampled return; those beyond ring_min_range
  std::vector<int> ring_of_all;  // ring index of each entry of `all` (scans with rings)
  std::vector<int> azimuth_hits = std::vector<int>(kAzimuthBins, 0);
  std::size_t stride = 1, returns = 0;
};

ElevationSample sample_elevations(const PointCloud& scan, const SensorEstimateConfig& c) {
  ElevationSample s;
  const std::size_t n = scan.size();
  const std::size_t cap = static_cast<std::size_t>(std::max(1, c.max_samples));
  if (n > cap) s.stride = n / cap + 1;
  if (s.stride % 2 == 0) ++s.stride;  // odd: no aliasing with the power-of-two ring counts of column-major scans
  const double lo2 = c.min_range * c.min_range, hi2 = c.max_range * c.max_range, far2 = c.ring_min_range * c.ring_min_range;
  const bool rings = scan.has_rings();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = scan.points[i];
    const double r2 = p.squaredNorm();
    if (!(r2 >= lo2 && r2 <= hi2)) continue;  // NaN fails too
    ++s.returns;
    if (i % s.stride != 0) continue;
    const double e = std::asin(std::clamp(p.z() / std::sqrt(r2), -1.0, 1.0)) * kRadToDeg;
    s.all.push_back(static_cast<float>(e));
    if (rings) s.ring_of_all.push_back(scan.ring[i]);
    if (r2 >= far2) s.far.push_back(static_cast<float>(e));
    const double az = fast_atan2(p.y(), p.x()) * kRadToDeg + 180.0;
    ++s.azimuth_hits[static_cast<std::size_t>(std::clamp(static_cast<int>(az), 0, kAzimuthBins - 1))];
  }
  return s;
}

double quantile(std::vector<float> v, double q) {
  const std::size_t k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/// Degrees of azimuth with returns: a degree counts when it holds at least 5 % of a populated degree's mean (stray
/// returns outside a solid-state lidar's field of view do not widen it).
double azimuth_coverage(const std::vector<int>& hits) {
  const int populated = static_cast<int>(std::count_if(hits.begin(), hits.end(), [](int h) { return h > 0; }));
  if (populated == 0) return 0.0;
  const double mean = static_cast<double>(std::accumulate(hits.begin(), hits.end(), 0)) / populated;
  return static_cast<double>(std::count_if(hits.begin(), hits.end(), [&](int h) { return h >= std::max(1.0, 0.05 * mean); }));
}

/// Strictly ascending copy (equal neighbours nudged apart): LidarModel::validate's rule.
std::vector<double> strictly_ascending(std::vector<double> a) {
  std::sort(a.begin(), a.end());
  for (std::size_t i = 1; i < a.size(); ++i) a[i] = std::max(a[i], a[i - 1] + 1e-3);
  return a;
}

/// Beam elevations from the scan's ring indices: the median elevation of each ring's sampled returns.
std::vector<double> ring_medians(const ElevationSample& s, int num_rings) {
  std::vector<std::vector<float>> per_ring(static_cast<std::size_t>(num_rings));
  for (std::size_t i = 0; i < s.all.size(); ++i) {
    if (s.ring_of_all[i] < num_rings) per_ring[static_cast<std::size_t>(s.ring_of_all[i])].push_back(s.all[i]);
  }
  std::vector<double> med(per_ring.size(), std::nan(""));
  for (std::size_t r = 0; r < per_ring.size(); ++r) {
    if (!per_ring[r].empty()) med[r] = quantile(per_ring[r], 0.5);
  }
  // Rings without a sampled return (sky): evenly between their known neighbours, or one degree beyond the last.
  for (std::size_t r = 0; r < med.size(); ++r) {
    if (!std::isnan(med[r])) continue;
    std::size_t a = r, b = r;
    while (a > 0 && std::isnan(med[a])) --a;
    while (b + 1 < med.size() && std::isnan(med[b])) ++b;
    const bool ha = !std::isnan(med[a]), hb = !std::isnan(med[b]);
    if (ha && hb)
      med[r] = med[a] + (med[b] - med[a]) * static_cast<double>(r - a) / static_cast<double>(b - a);
    else if (ha)
      med[r] = med[a] + static_cast<double>(r - a);
    else if (hb)
      med[r] = med[b] - static_cast<double>(b - r);
    else
      med[r] = static_cast<double>(r);
  }
  return strictly_ascending(std::move(med));
}

/// Beam elevations as the peaks of the elevation histogram; empty when the returns do not fall on distinct beams.
std::vector<double> histogram_rings(const std::vector<float>& e, double lo, double hi, const SensorEstimateConfig& c,
                                    std::vector<double>* peak_mass) {
  const double bin = c.bin_deg;
  const int nb = static_cast<int>(std::ceil((hi - lo) / bin)) + 1;
  if (nb < 8 || e.empty()) return {};
  std::vector<double> h(static_cast<std::size_t>(nb), 0.0);
  for (const float v : e) {
    const int b = static_cast<int>((v - lo) / bin);
    if (b >= 0 && b < nb) h[static_cast<std::size_t>(b)] += 1.0;
  }
  std::vector<double> sm(h.size(), 0.0);  // [1 2 1] smoothing against a peak split over two bins
  for (int i = 0; i < nb; ++i) {
    const auto at = [&](int j) { return j >= 0 && j < nb ? h[static_cast<std::size_t>(j)] : 0.0; };
    sm[static_cast<std::size_t>(i)] = at(i - 1) + 2.0 * at(i) + at(i + 1);
  }
  // Local maxima, merged while the valley between two is not deep (less than half the lower peak).
  std::vector<int> peaks;
  for (int i = 1; i + 1 < nb; ++i) {
    const double v = sm[static_cast<std::size_t>(i)];
    if (!(v > 0.0 && v > sm[static_cast<std::size_t>(i - 1)] && v >= sm[static_cast<std::size_t>(i + 1)])) continue;
    if (!peaks.empty()) {
      const int p = peaks.back();
      const double valley = *std::min_element(sm.begin() + p, sm.begin() + i + 1);
      if (valley > 0.5 * std::min(sm[static_cast<std::size_t>(p)], v)) {
        if (v > sm[static_cast<std::size_t>(p)]) peaks.back() = i;
        continue;
      }
    }
    peaks.push_back(i);
  }
  // Each peak's mass and centre within +-2 bins; peaks far lighter than the typical beam are stray returns.
  std::vector<double> mass, centre;
  for (const int p : peaks) {
    double m = 0.0, mx = 0.0;
    for (int j = std::max(0, p - 2); j <= std::min(nb - 1, p + 2); ++j) {
      m += h[static_cast<std::size_t>(j)];
      mx += h[static_cast<std::size_t>(j)] * (lo + (j + 0.5) * bin);
    }
    mass.push_back(m);
    centre.push_back(m > 0.0 ? mx / m : lo + (p + 0.5) * bin);
  }
  if (mass.empty()) return {};
  std::vector<double> sorted_mass = mass;
  std::nth_element(sorted_mass.begin(), sorted_mass.begin() + static_cast<std::ptrdiff_t>(sorted_mass.size() / 2), sorted_mass.end());
  const double typical = sorted_mass[sorted_mass.size() / 2];
  std::vector<double> rings;
  double on_peaks = 0.0;
  for (std::size_t i = 0; i < mass.size(); ++i) {
    if (mass[i] < 0.15 * typical) continue;
    rings.push_back(centre[i]);
    peak_mass->push_back(mass[i]);
    on_peaks += mass[i];
  }
  if (static_cast<int>(rings.size()) < c.min_rings || on_peaks < c.ring_mass_fraction * static_cast<double>(e.size())) {
    peak_mass->clear();
    return {};
  }
  return strictly_ascending(std::move(rings));
}

/// Sampled returns of the beam that has the most: those within a third of the spacing (at most 0.15 deg) of its elevation.
/// The windows of neighbouring beams do not overlap (each is at most a third of the gap), so each return can only lie
/// in the last window that starts at or below it: O(returns log beams), no sort of the returns.
std::size_t fullest_beam(const std::vector<float>& e, const std::vector<double>& beams) {
  if (beams.empty()) return 0;
  std::vector<float> lo(beams.size()), hi(beams.size());
  for (std::size_t i = 0; i < beams.size(); ++i) {
    const double gap = std::min(i > 0 ? beams[i] - beams[i - 1] : 1.0, i + 1 < beams.size() ? beams[i + 1] - beams[i] : 1.0);
    const double w = std::min(0.15, gap / 3.0);
    lo[i] = static_cast<float>(beams[i] - w);
    hi[i] = static_cast<float>(beams[i] + w);
  }
  std::vector<std::size_t> count(beams.size(), 0);
  for (const float v : e) {
    // The first beam whose window starts above v; v can only lie in the window before it.
    const auto above = std::upper_bound(lo.begin(), lo.end(), v);
    if (above == lo.begin()) continue;
    const auto i = static_cast<std::size_t>(above - lo.begin()) - 1;
    if (v <= hi[i]) ++count[i];
  }
  return *std::max_element(count.begin(), count.end());
}

/// Rings that match a preset's beams (same count, every elevation within 0.5 deg) take the preset's datasheet
/// elevations, and its columns unless the scan's differ by more than a quarter (another column mode).
void snap_to_preset(LidarModel* m) {
  for (const std::string& name : lidar_model_names()) {
    const LidarModel p = *lidar_model_from_name(name);
    if (p.num_rings != m->num_rings) continue;
    double worst = 0.0;
    for (int i = 0; i < p.num_rings; ++i)
      worst = std::max(worst, std::abs(p.vertical_angles_deg[static_cast<std::size_t>(i)] - m->vertical_angles_deg[static_cast<std::size_t>(i)]));
    if (worst > 0.5) continue;
    m->vertical_angles_deg = p.vertical_angles_deg;
    if (std::abs(m->azimuth_steps - p.azimuth_steps) <= p.azimuth_steps / 4) m->azimuth_steps = p.azimuth_steps;
    m->name = "auto (like " + p.name + ")";
    return;
  }
}

/// Beams found only in far returns (a handheld sensor's lower beams hit the floor within a few metres) leave part of
/// the fan without rings: beams at the median spacing are added out to the returns' extremes.
void extend_to_fan(double lo, double hi, std::vector<double>* rings) {
  std::vector<double>& a = *rings;
  if (a.size() < 2) return;
  std::vector<double> gaps;
  for (std::size_t i = 1; i < a.size(); ++i) gaps.push_back(a[i] - a[i - 1]);
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
  const double step = gaps[gaps.size() / 2];
  if (!(step > 0.0)) return;
  std::vector<double> below;
  for (double e = a.front() - step; e >= lo - 0.5 * step; e -= step) below.push_back(e);
  a.insert(a.begin(), below.rbegin(), below.rend());
  for (double e = a.back() + step; e <= hi + 0.5 * step; e += step) a.push_back(e);
}

std::string fmt_deg(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%+.1f", v);
  return buf;
}

}  // namespace

std::optional<std::string> SensorEstimateConfig::validate() const {
  if (!(min_range >= 0.0 && max_range > min_range)) return std::string("need 0 <= min_range < max_range");
  if (!(bin_deg > 0.0 && bin_deg <= 1.0)) return std::string("bin_deg must be in (0, 1]");
  if (!(ring_mass_fraction > 0.0 && ring_mass_fraction <= 1.0)) return std::string("ring_mass_fraction must be in (0, 1]");
  if (min_rings < 2) return std::string("min_rings must be >= 2");
  if (max_samples < 100) return std::string("max_samples must be >= 100");
  if (!(unstructured_row_deg > 0.0) || !(pixel_occupancy > 0.0)) return std::string("unstructured_row_deg and pixel_occupancy must be > 0");
  return std::nullopt;
}

SensorEstimate estimate_sensor(const PointCloud& scan, const SensorEstimateConfig& c) {
  SensorEstimate est;
  est.model.name = "auto";
  est.model.min_range = c.min_range;
  est.model.max_range = c.max_range;
  const ElevationSample s = sample_elevations(scan, c);
  est.returns = s.returns;
  if (s.all.size() < 50) {
    est.error =
        "scan has " + std::to_string(s.returns) + " returns within " + fmt_deg(c.min_range) + ".." + fmt_deg(c.max_range) + " m (need >= 50 sampled)";
    return est;
  }
  est.elevation_min_deg = quantile(s.all, 0.005);
  est.elevation_max_deg = quantile(s.all, 0.995);
  est.azimuth_coverage_deg = azimuth_coverage(s.azimuth_hits);
  const double coverage = std::max(1.0, est.azimuth_coverage_deg) / 360.0;
  std::vector<double> ring_mass;
  if (scan.has_rings()) {
    est.model.vertical_angles_deg = ring_medians(s, scan.num_rings);
    est.rings_from_scan = est.rings_resolved = true;
  } else {
    const std::vector<float>& e = s.far.size() >= 2000 ? s.far : s.all;
    est.model.vertical_angles_deg = histogram_rings(e, est.elevation_min_deg - 1.0, est.elevation_max_deg + 1.0, c, &ring_mass);
    est.rings_resolved = !est.model.vertical_angles_deg.empty();
    if (est.rings_resolved) extend_to_fan(est.elevation_min_deg, est.elevation_max_deg, &est.model.vertical_angles_deg);
  }
  if (est.rings_resolved) {
    // Columns: the fullest beam's returns over one revolution (a ground beam misses few).
    if (!scan.has_rings()) {
      const double per_beam = static_cast<double>(fullest_beam(s.all, est.model.vertical_angles_deg)) * static_cast<double>(s.stride);
      est.model.azimuth_steps = std::clamp(static_cast<int>(std::lround(per_beam / coverage)), 64, 8192);
    } else {  // the sample is of all returns, not of one ring: count the fullest ring exactly
      std::vector<std::size_t> count(static_cast<std::size_t>(scan.num_rings), 0);
      for (std::size_t i = 0; i < scan.size(); ++i) {
        if (scan.ring[i] < scan.num_rings && scan.points[i].allFinite()) ++count[scan.ring[i]];
      }
      est.model.azimuth_steps =
          std::clamp(static_cast<int>(std::lround(static_cast<double>(*std::max_element(count.begin(), count.end())) / coverage)), 64, 8192);
    }
  } else {
    // Rows about twice as tall as a pixel that holds pixel_occupancy returns when square (a spinning lidar's columns are
    // finer than its beams), between 0.4 deg and unstructured_row_deg.
    const double span = std::max(1.0, est.elevation_max_deg - est.elevation_min_deg);
    const double square = std::sqrt(span * 360.0 * coverage * c.pixel_occupancy / static_cast<double>(std::max<std::size_t>(1, s.returns)));
    const double row_deg = std::clamp(2.0 * square, 0.4, c.unstructured_row_deg);
    const int rows = std::clamp(static_cast<int>(std::lround(span / row_deg)), 8, 128);
    for (int i = 0; i < rows; ++i) est.model.vertical_angles_deg.push_back(est.elevation_min_deg + span * (i + 0.5) / rows);
    const double cols = static_cast<double>(s.returns) / (c.pixel_occupancy * rows) / coverage;
    est.model.azimuth_steps = std::clamp(static_cast<int>(std::lround(cols)), 256, 4096);
  }
  est.model.num_rings = static_cast<int>(est.model.vertical_angles_deg.size());
  if (est.rings_resolved) snap_to_preset(&est.model);
  est.ok = true;
  return est;
}

std::string SensorEstimate::describe() const {
  if (!ok) return "no estimate: " + error;
  std::string s;
  if (rings_resolved) {
    s = std::to_string(model.num_rings) + " rings between " + fmt_deg(model.vertical_angles_deg.front()) + " and " +
        fmt_deg(model.vertical_angles_deg.back()) + " deg";
    if (rings_from_scan) s += " (ring field)";
    if (model.name != "auto") s += ", " + model.name.substr(5);
  } else {
    s = "no ring pattern: " + std::to_string(model.num_rings) + " rows over " + fmt_deg(elevation_min_deg) + ".." + fmt_deg(elevation_max_deg) +
        " deg";
  }
  s += ", " + std::to_string(model.azimuth_steps) + " columns";
  if (azimuth_coverage_deg < 350.0) s += ", " + std::to_string(static_cast<int>(azimuth_coverage_deg)) + " deg of azimuth";
  return s;
}

std::optional<std::string> preset_mismatch(const LidarModel& preset, const SensorEstimate& est) {
  if (!est.ok || preset.vertical_angles_deg.empty()) return std::nullopt;
  const double lo = preset.vertical_angles_deg.front(), hi = preset.vertical_angles_deg.back();
  const double margin = 1.5;  // [deg] mounting tilt and per-unit calibration
  bool off = est.elevation_min_deg < lo - margin || est.elevation_max_deg > hi + margin;
  // A much narrower fan than the preset's (an OS2 read as a VLP-16): the rows land on the wrong beams too.
  off = off || (est.elevation_max_deg - est.elevation_min_deg) < 0.6 * (hi - lo);
  if (est.rings_from_scan && est.model.num_rings != preset.num_rings) off = true;
  if (!off) return std::nullopt;
  std::string seen = est.rings_resolved ? std::to_string(est.model.num_rings) + " rings" : std::string("returns without distinct rings");
  return "scans have " + seen + " between " + fmt_deg(est.elevation_min_deg) + " and " + fmt_deg(est.elevation_max_deg) + " deg; --sensor " +
         preset.name + " expects " + std::to_string(preset.num_rings) + " between " + fmt_deg(lo) + " and " + fmt_deg(hi);
}

std::optional<LidarModel> sensor_model_from_choice(const std::string& sensor, const std::vector<double>& elevations_deg, int columns) {
  if (sensor == "custom") {
    LidarModel m;
    m.name = "custom";
    m.num_rings = static_cast<int>(elevations_deg.size());
    m.vertical_angles_deg = elevations_deg;
    m.azimuth_steps = columns;
    m.min_range = 0.5;
    m.max_range = 200.0;
    return m;
  }
  const std::optional<LidarModel> m = lidar_model_from_name(sensor);
  if (m && m->pattern != LidarModel::ScanPattern::kSpinning) return std::nullopt;  // no rings to fix: read each scan
  return m;
}

const LidarModel* model_for_scan(const std::optional<LidarModel>& fixed, const PointCloud& scan, SensorEstimate* seen) {
  *seen = estimate_sensor(scan);
  if (fixed) return &*fixed;
  return seen->ok ? &seen->model : nullptr;
}

std::string sensor_choices() {
  std::string s = "auto, custom";
  for (const std::string& n : lidar_model_names()) s += ", " + n;
  for (const std::string& n : lidar_pattern_model_names()) s += ", " + n + " (as auto)";
  return s;
}

std::optional<std::string> validate_sensor_choice(const std::string& sensor, const std::vector<double>& elevations_deg, int columns) {
  if (sensor == "auto") return std::nullopt;
  if (sensor == "custom") {
    if (elevations_deg.size() < 2) return std::string("sensor: custom needs sensor_elevations_deg (two or more beams, ascending)");
    if (auto e = sensor_model_from_choice(sensor, elevations_deg, columns)->validate()) return "sensor: custom: " + *e;
    return std::nullopt;
  }
  if (!lidar_model_from_name(sensor)) return "sensor: unknown lidar model '" + sensor + "' (" + sensor_choices() + ")";
  return std::nullopt;
}

}  // namespace loopd
