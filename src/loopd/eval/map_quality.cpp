#include "loopd/eval/map_quality.hpp"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <tuple>
#include <nlohmann/json.hpp>

#include "loopd/base/kdtree.hpp"

namespace loopd {
namespace {

constexpr std::size_t kMaxMovers = 1000000;  ///< boxes in one movers file

bool finite(const Eigen::Vector3f& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

std::vector<Eigen::Vector3f> finite_points(const PointCloud& cloud) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(cloud.size());
  for (const auto& p : cloud.points)
    if (finite(p)) out.push_back(p);
  return out;
}

bool inside(const Eigen::Vector3f& p, const MapMoverBox& b, double margin) {
  for (int k = 0; k < 3; ++k)
    if (p[k] < b.min[k] - margin || p[k] > b.max[k] + margin) return false;
  return true;
}

using Json = nlohmann::json;

/// An integer field of `obj` in [lo, hi] into *v, or the reason.
std::optional<std::string> integer_field(const Json& obj, const char* key, const std::string& where, std::int64_t lo, std::int64_t hi,
                                         std::int64_t* v) {
  const auto it = obj.find(key);
  if (it == obj.end()) return where + ": no '" + key + "'";
  if (it->is_number_unsigned()) {
    const auto u = it->get<std::uint64_t>();
    if (u > static_cast<std::uint64_t>(hi)) return where + "." + key + ": " + std::to_string(u) + " is out of range";
    *v = static_cast<std::int64_t>(u);
  } else if (it->is_number_integer()) {
    *v = it->get<std::int64_t>();
  } else {
    return where + "." + key + ": not an integer";
  }
  if (*v < lo || *v > hi)
    return where + "." + key + ": " + std::to_string(*v) + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return std::nullopt;
}

std::optional<std::string> vector_field(const Json& obj, const char* key, const std::string& where, Eigen::Vector3d* v) {
  const auto it = obj.find(key);
  if (it == obj.end()) return where + ": no '" + key + "'";
  if (!it->is_array() || it->size() != 3) return where + "." + key + ": not an array of 3 numbers";
  for (std::size_t k = 0; k < 3; ++k) {
    const Json& e = (*it)[k];
    const double d = e.is_number() ? e.get<double>() : std::numeric_limits<double>::quiet_NaN();
    if (!std::isfinite(d)) return where + "." + key + "[" + std::to_string(k) + "]: not a finite number";
    (*v)[static_cast<int>(k)] = d;
  }
  return std::nullopt;
}

std::optional<std::string> parse_mover(const Json& m, const std::string& where, MapMoverBox* box) {
  if (!m.is_object()) return where + ": not an object";
  std::int64_t id = 0, variant = 0;
  constexpr std::int64_t kIntMax = std::numeric_limits<int>::max();
  if (auto e = integer_field(m, "id", where, 0, kIntMax, &id)) return e;
  if (auto e = integer_field(m, "variant", where, 0, kIntMax, &variant)) return e;
  if (auto e = vector_field(m, "min", where, &box->min)) return e;
  if (auto e = vector_field(m, "max", where, &box->max)) return e;
  for (int k = 0; k < 3; ++k)
    if (box->min[k] > box->max[k]) return where + ": min[" + std::to_string(k) + "] is greater than max[" + std::to_string(k) + "]";
  const auto left = m.find("left");
  if (left != m.end() && !left->is_boolean()) return where + ".left: not a boolean";
  box->left = left == m.end() || left->get<bool>();
  box->id = static_cast<int>(id);
  box->variant = static_cast<int>(variant);
  return std::nullopt;
}

std::optional<std::string> parse_movers_document(const Json& doc, std::vector<MapMoverBox>* out) {
  if (!doc.is_object()) return std::string("movers file: not a JSON object");
  const auto format = doc.find("format");
  if (format == doc.end() || !format->is_string() || format->get<std::string>() != "loopd-movers")
    return std::string("movers file: 'format' is not \"loopd-movers\"");
  std::int64_t version = 0;
  if (auto e = integer_field(doc, "version", "movers file", 0, std::numeric_limits<std::int32_t>::max(), &version)) return e;
  if (version != 1) return "movers file: version " + std::to_string(version) + " is not supported (expected 1)";
  const auto movers = doc.find("movers");
  if (movers == doc.end() || !movers->is_array()) return std::string("movers file: 'movers' is not an array");
  if (movers->size() > kMaxMovers) return "movers file: more than " + std::to_string(kMaxMovers) + " movers";
  std::vector<MapMoverBox> boxes(movers->size());
  for (std::size_t i = 0; i < boxes.size(); ++i)
    if (auto e = parse_mover((*movers)[i], "movers[" + std::to_string(i) + "]", &boxes[i])) return e;
  *out = std::move(boxes);
  return std::nullopt;
}

/// Value at quantile q (0..1) of `v` (reordered), nearest rank.
double quantile(std::vector<double>* v, double q) {
  const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v->size()))) - 1;
  const auto nth = v->begin() + static_cast<std::ptrdiff_t>(std::min(k, v->size() - 1));
  std::nth_element(v->begin(), nth, v->end());
  return *nth;
}

}  // namespace

std::optional<std::string> parse_movers_json(const std::string& text, std::vector<MapMoverBox>* out) {
  try {
    const Json doc = Json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (doc.is_discarded()) return std::string("movers file: not valid JSON");
    return parse_movers_document(doc, out);
  } catch (const std::exception& e) {  // allocation failures; the checks above leave nothing else to throw
    return std::string("movers file: ") + e.what();
  }
}

std::optional<std::string> MapQualityConfig::validate() const {
  if (!(completeness_radius > 0.0) || !std::isfinite(completeness_radius)) return "completeness_radius must be > 0 m";
  if (!(mover_margin >= 0.0) || !std::isfinite(mover_margin)) return "mover_margin must be >= 0 m";
  return std::nullopt;
}

std::int64_t count_mover_points(const PointCloud& cloud, const std::vector<MapMoverBox>& movers, double margin) {
  std::int64_t n = 0;
  for (const auto& p : cloud.points) {
    if (!finite(p)) continue;
    // In a box the object left, and not inside where an object stands at the end (a car moved along the kerb).
    bool stale = false, current = false;
    for (const auto& b : movers) {
      if (!inside(p, b, margin)) continue;
      (b.left ? stale : current) = true;
    }
    n += stale && !current ? 1 : 0;
  }
  return n;
}

MapQuality map_quality(const PointCloud& map, const PointCloud& reference, const std::vector<MapMoverBox>& movers, const MapQualityConfig& config) {
  MapQuality q;
  const std::vector<Eigen::Vector3f> map_points = finite_points(map), ref_points = finite_points(reference);
  q.points = static_cast<std::int64_t>(map_points.size());
  q.reference_points = static_cast<std::int64_t>(ref_points.size());
  if (!map_points.empty() && !ref_points.empty()) {
    const KdTree3f ref_tree(ref_points);
    std::vector<double> dist(map_points.size());
    double sum = 0.0;
    for (std::size_t i = 0; i < map_points.size(); ++i) {
      int index = -1;
      float d2 = 0.f;
      ref_tree.nearest(map_points[i], &index, &d2);
      dist[i] = std::sqrt(static_cast<double>(d2));
      sum += dist[i];
    }
    q.mean_error = sum / static_cast<double>(dist.size());
    q.p95_error = quantile(&dist, 0.95);
  }
  if (!ref_points.empty()) {
    std::int64_t covered = 0;
    if (!map_points.empty()) {
      const KdTree3f map_tree(map_points);
      const double r2 = config.completeness_radius * config.completeness_radius;
      for (const auto& p : ref_points) {
        int index = -1;
        float d2 = 0.f;
        if (map_tree.nearest(p, &index, &d2) && static_cast<double>(d2) <= r2) ++covered;
      }
    }
    q.completeness = static_cast<double>(covered) / static_cast<double>(ref_points.size());
  }
  q.moving_points = count_mover_points(map, movers, config.mover_margin);
  q.moving_points_share = q.points > 0 ? static_cast<double>(q.moving_points) / static_cast<double>(q.points) : 0.0;
  return q;
}

}  // namespace loopd
