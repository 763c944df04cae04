// Roadway-section noise removal (Ren 2019, Sec. 3.5). Step 1 (normals from the trajectory, skip rules) is
// cut_stations; Step 2 (the band |d_i| <= delta / 2, Eq. 13) and Step 3 (the parts S1..S4) are cut_section; Step 4 (the
// curves) is roadway_section_fit.cpp. Only points inside all four fitted surfaces are removed, so openings stay.
#include "loopd/map3d/roadway_noise.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <unordered_map>

#include "loopd/map3d/roadway_noise_internal.hpp"

namespace loopd {
namespace {
constexpr double kIndexCell = 1.0;  // [m] edge of the map's bucket cells
constexpr double kMinUpNorm = 0.1;  // a step steeper than ~84 deg has no usable 'up' in its section plane
constexpr std::int64_t kCellOffset = std::int64_t{1} << 20;
constexpr std::int64_t kCellLimit = std::int64_t{1} << 21;

double radians(double deg) { return deg * M_PI / 180.0; }

/// One section: the station on the trajectory, the section normal and the section's 2D frame (lateral, up).
struct Station {
  Eigen::Vector3d origin, normal, lateral, up;
  std::uint32_t id = 0;
};

// Ren 2019, Sec. 3.5, Step 1: each step between consecutive keyframes gives the normal (Eq. 12) of the stations
// interpolated along it, unless a skip rule trips (distance, curvature, heading; a step counts under the first).
std::vector<Station> cut_stations(const std::vector<Eigen::Isometry3d>& T_world_keyframe, const RoadwayNoiseConfig& config,
                                  RoadwayNoiseResult* result) {
  const double cos_turn = std::cos(radians(config.max_direction_change_deg)), cos_heading = std::cos(radians(config.max_heading_offset_deg));
  std::vector<Station> stations;
  Eigen::Vector3d previous_direction = Eigen::Vector3d::Zero();
  for (std::size_t k = 1; k < T_world_keyframe.size(); ++k) {
    const Eigen::Vector3d step = T_world_keyframe[k].translation() - T_world_keyframe[k - 1].translation();
    const double length = step.norm();
    if (length < 1e-6) continue;  // standing still: no normal
    const Eigen::Vector3d direction = step / length;
    const bool turned = previous_direction.squaredNorm() > 0 && direction.dot(previous_direction) < cos_turn;
    previous_direction = direction;
    const Eigen::Vector3d heading = T_world_keyframe[k].linear().col(0).normalized();
    if (length > config.max_step) {
      ++result->skipped_step;
    } else if (turned) {
      ++result->skipped_curvature;
    } else if (direction.dot(heading) < cos_heading) {
      ++result->skipped_heading;
    } else {
      Eigen::Vector3d up = Eigen::Vector3d::UnitZ() - direction.z() * direction;
      if (up.norm() < kMinUpNorm) {
        const Eigen::Vector3d sensor_up = T_world_keyframe[k].linear().col(2);
        up = sensor_up - sensor_up.dot(direction) * direction;
      }
      if (up.norm() < kMinUpNorm) continue;
      up.normalize();
      const int count = static_cast<int>(std::ceil(length / config.station_spacing));
      for (int j = 0; j < count; ++j) {
        Station s;
        s.origin = T_world_keyframe[k - 1].translation() + step * ((j + 0.5) / count);
        s.normal = direction;
        s.up = up;
        s.lateral = up.cross(direction);  // left of the direction of travel
        s.id = static_cast<std::uint32_t>(stations.size());
        stations.push_back(s);
      }
    }
  }
  return stations;
}

/// The map's points bucketed by cubic cell (counting sort, point order kept within a cell).
class CellIndex {
 public:
  CellIndex(const std::vector<Eigen::Vector3f>& points, double cell) : cell_(cell) {
    std::vector<std::uint32_t> cell_of_point(points.size(), kNone);
    std::vector<std::uint32_t> counts;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d p = points[i].cast<double>() / cell_;
      if (!p.allFinite()) continue;
      std::uint64_t key = 0;
      if (!pack(std::floor(p.x()), std::floor(p.y()), std::floor(p.z()), &key)) continue;
      const auto [it, inserted] = cell_of_key_.emplace(key, static_cast<std::uint32_t>(counts.size()));
      if (inserted) counts.push_back(0);
      cell_of_point[i] = it->second;
      ++counts[it->second];
    }
    begin_.assign(counts.size() + 1, 0);
    for (std::size_t c = 0; c < counts.size(); ++c) begin_[c + 1] = begin_[c] + counts[c];
    members_.resize(begin_.back());
    std::vector<std::uint32_t> fill(begin_.begin(), begin_.end() - 1);
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (cell_of_point[i] != kNone) members_[fill[cell_of_point[i]]++] = static_cast<std::uint32_t>(i);
    }
  }

  /// Calls visit(i) for the points of every cell that may hold a point within `half` of the station's plane and within
  /// `radius` of the station in that plane (a superset: the caller tests each point).
  template <typename Visit>
  void visit_slab(const Station& s, double half, double radius, Visit&& visit) const {
    Eigen::Vector3d extent;
    for (int axis = 0; axis < 3; ++axis) {
      const double n = std::abs(s.normal[axis]);
      extent[axis] = radius * std::sqrt(std::max(0.0, 1 - n * n)) + half * n;
    }
    const Eigen::Vector3d lo = ((s.origin - extent) / cell_).array().floor(), hi = ((s.origin + extent) / cell_).array().floor();
    const double slack = half + 0.5 * std::sqrt(3.0) * cell_;  // a cell's points lie within this of its centre's plane distance
    for (double x = lo.x(); x <= hi.x(); ++x) {
      for (double y = lo.y(); y <= hi.y(); ++y) {
        for (double z = lo.z(); z <= hi.z(); ++z) {
          const Eigen::Vector3d centre = (Eigen::Vector3d(x, y, z).array() + 0.5) * cell_;
          if (std::abs(s.normal.dot(centre - s.origin)) > slack) continue;
          std::uint64_t key = 0;
          if (!pack(x, y, z, &key)) continue;
          const auto it = cell_of_key_.find(key);
          if (it == cell_of_key_.end()) continue;
          for (std::uint32_t m = begin_[it->second]; m < begin_[it->second + 1]; ++m) visit(members_[m]);
        }
      }
    }
  }

 private:
  static constexpr std::uint32_t kNone = ~std::uint32_t{0};

  // Cell coordinates (whole numbers as doubles) packed as 21 bits each, as base/voxel_grid.hpp's keys.
  static bool pack(double x, double y, double z, std::uint64_t* key) {
    const double lo = -static_cast<double>(kCellOffset), hi = static_cast<double>(kCellLimit - kCellOffset);
    if (!(x >= lo && y >= lo && z >= lo && x < hi && y < hi && z < hi)) return false;
    const auto bits = [](double v) { return static_cast<std::uint64_t>(static_cast<std::int64_t>(v) + kCellOffset); };
    *key = (bits(x) << 42) | (bits(y) << 21) | bits(z);
    return true;
  }

  double cell_;
  std::unordered_map<std::uint64_t, std::uint32_t> cell_of_key_;
  std::vector<std::uint32_t> begin_;    // cell c holds members_[begin_[c], begin_[c + 1])
  std::vector<std::uint32_t> members_;  // point indices, grouped by cell
};

struct SectionOutcome {
  bool enclosed = false;
  std::vector<std::uint32_t> band;    // points of the delta band (filled only when enclosed)
  std::vector<std::uint32_t> inside;  // band points inside all four surfaces: noise
};

struct BandPoint {
  std::uint32_t index;
  double a, b;
};

// Ren 2019, Sec. 3.5, Steps 2-4 at one station: the slab's points projected on the section plane, split into the four
// parts, a curve fitted to each; an enclosed section removes its band points that are inside every surface.
SectionOutcome cut_section(const CellIndex& index, const std::vector<Eigen::Vector3f>& points, const Station& s, const RoadwayNoiseConfig& config) {
  const double half_fit = 0.5 * std::max(config.fit_thickness, config.section_thickness), half_band = 0.5 * config.section_thickness;
  const double radius_sq = config.section_radius * config.section_radius;
  std::array<std::vector<Eigen::Vector2d>, detail::kRoadwaySectors> sectors;
  std::vector<BandPoint> band;
  index.visit_slab(s, half_fit, config.section_radius, [&](std::uint32_t i) {
    const Eigen::Vector3d d = points[i].cast<double>() - s.origin;
    const double along = d.dot(s.normal);
    if (std::abs(along) > half_fit) return;
    const double a = d.dot(s.lateral), b = d.dot(s.up);
    if (a * a + b * b > radius_sq) return;
    sectors[static_cast<std::size_t>(detail::sector_of(a, b))].emplace_back(a, b);
    if (std::abs(along) <= half_band) band.push_back({i, a, b});
  });
  SectionOutcome outcome;
  std::seed_seq seed{config.seed, s.id};
  std::mt19937 rng(seed);
  std::array<detail::SectionCurve, detail::kRoadwaySectors> curves;
  std::array<double, detail::kRoadwaySectors> station_side{};  // sign of the station's distance to each curve
  for (std::size_t k = 0; k < curves.size(); ++k) {
    const auto curve = detail::fit_section_curve(sectors[k], static_cast<detail::RoadwaySector>(k), config, &rng);
    if (!curve) return outcome;
    const double station_distance = curve->signed_distance(0, 0);
    if (std::abs(station_distance) <= config.inlier_distance) return outcome;  // a station on a surface is not enclosed by it
    curves[k] = *curve;
    station_side[k] = station_distance > 0 ? 1.0 : -1.0;
  }
  outcome.enclosed = true;
  outcome.band.reserve(band.size());
  for (const BandPoint& p : band) {
    outcome.band.push_back(p.index);
    bool inside = true;
    for (std::size_t k = 0; k < curves.size() && inside; ++k) inside = station_side[k] * curves[k].signed_distance(p.a, p.b) > config.inlier_distance;
    if (inside) outcome.inside.push_back(p.index);
  }
  return outcome;
}
}  // namespace

std::optional<std::string> RoadwayNoiseConfig::validate() const {
  if (!(section_thickness > 0)) return "section_thickness must be > 0";
  if (!(station_spacing > 0)) return "station_spacing must be > 0";
  if (!(fit_thickness >= section_thickness)) return "fit_thickness must be >= section_thickness";
  if (!(max_step > 0)) return "max_step must be > 0";
  if (!(max_direction_change_deg > 0 && max_direction_change_deg <= 180)) return "max_direction_change_deg must be in (0, 180]";
  if (!(max_heading_offset_deg > 0 && max_heading_offset_deg <= 180)) return "max_heading_offset_deg must be in (0, 180]";
  if (!(section_radius > 0)) return "section_radius must be > 0";
  if (!(max_surface_tilt_deg > 0 && max_surface_tilt_deg < 90)) return "max_surface_tilt_deg must be in (0, 90)";
  if (ransac_iterations < 1) return "ransac_iterations must be >= 1";
  if (ransac_max_points < 3) return "ransac_max_points must be >= 3";
  if (!(inlier_distance > 0)) return "inlier_distance must be > 0";
  if (min_sector_points < 3) return "min_sector_points must be >= 3";
  if (!(min_inlier_share > 0 && min_inlier_share <= 1)) return "min_inlier_share must be in (0, 1]";
  if (num_threads < 0) return "num_threads must be >= 0";
  return std::nullopt;
}

RoadwayNoiseResult find_roadway_noise(const PointCloud& map_world, const std::vector<Eigen::Isometry3d>& T_world_keyframe,
                                      const RoadwayNoiseConfig& config) {
  RoadwayNoiseResult result;
  result.remove.assign(map_world.size(), 0);
  result.in_tunnel.assign(map_world.size(), 0);
  if (auto error = config.validate()) {
    result.error = "invalid RoadwayNoiseConfig: " + *error;
    std::cerr << "find_roadway_noise: " << result.error << "\n";
    return result;
  }
  const std::vector<Station> stations = cut_stations(T_world_keyframe, config, &result);
  const CellIndex index(map_world.points, kIndexCell);
  std::vector<SectionOutcome> outcomes(stations.size());
  const int threads = config.num_threads > 0 ? config.num_threads : omp_get_max_threads();
  const auto num_stations = static_cast<std::int64_t>(stations.size());
#pragma omp parallel for num_threads(threads) schedule(dynamic, 4)
  for (std::int64_t i = 0; i < num_stations; ++i) {
    const auto s = static_cast<std::size_t>(i);
    outcomes[s] = cut_section(index, map_world.points, stations[s], config);
  }
  for (const SectionOutcome& outcome : outcomes) {
    ++result.stations;
    ++(outcome.enclosed ? result.tunnel_stations : result.not_enclosed);
    for (const std::uint32_t i : outcome.band) result.in_tunnel[i] = 1;
    for (const std::uint32_t i : outcome.inside) result.remove[i] = 1;
  }
  for (const std::uint8_t r : result.remove) result.removed += r;
  return result;
}

}  // namespace loopd
