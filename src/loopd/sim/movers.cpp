#include "loopd/sim/movers.hpp"

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <utility>

namespace loopd {
namespace {

/// World-frame bounds of one primitive.
void primitive_bounds(const Town& town, const Primitive& p, Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  const Eigen::Vector3d r(p.radius, p.radius, 0.0);
  switch (p.type) {
    case PrimitiveType::kCylinder:
      *lo = p.a - r;
      *hi = Eigen::Vector3d(p.a.x() + p.radius, p.a.y() + p.radius, p.b.z());
      break;
    case PrimitiveType::kSphere:
      *lo = p.a - Eigen::Vector3d::Constant(p.radius);
      *hi = p.a + Eigen::Vector3d::Constant(p.radius);
      break;
    case PrimitiveType::kSlab: {
      double z0 = 1e300, z1 = -1e300;
      for (double x : {p.a.x(), p.b.x()})
        for (double y : {p.a.y(), p.b.y()}) z0 = std::min(z0, town.ground_height(x, y)), z1 = std::max(z1, town.ground_height(x, y) + p.a.z());
      *lo = Eigen::Vector3d(p.a.x(), p.a.y(), z0);
      *hi = Eigen::Vector3d(p.b.x(), p.b.y(), z1);
      break;
    }
    case PrimitiveType::kBox:
    default:
      *lo = p.a;
      *hi = p.b;
      break;
  }
}

}  // namespace

std::vector<MoverBox> changing_movers(const Drive& drive) {
  std::set<int> visits;
  for (const DriveScan& s : drive.scans) visits.insert(s.visit + drive.car_visit_offset);
  std::set<int> changing;
  for (int id = 0; id < drive.town.num_movables; ++id) {
    std::set<int> shown;
    for (int v : visits) shown.insert(drive.town.active_variant(id, v));
    if (shown.size() >= 2) changing.insert(id);
  }
  std::map<std::pair<int, int>, MoverBox> boxes;
  for (const Primitive& p : drive.town.primitives) {
    if (p.movable_id < 0 || !changing.count(p.movable_id)) continue;
    Eigen::Vector3d lo, hi;
    primitive_bounds(drive.town, p, &lo, &hi);
    const auto key = std::make_pair(p.movable_id, p.variant);
    auto it = boxes.find(key);
    if (it == boxes.end()) {
      boxes[key] = MoverBox{p.movable_id, p.variant, lo, hi};
    } else {
      it->second.min = it->second.min.cwiseMin(lo);
      it->second.max = it->second.max.cwiseMax(hi);
    }
  }
  std::vector<MoverBox> out;
  out.reserve(boxes.size());
  const int last_visit = drive.scans.empty() ? 0 : drive.scans.back().visit + drive.car_visit_offset;
  for (const auto& [key, box] : boxes) {
    out.push_back(box);
    out.back().left = drive.town.active_variant(box.movable_id, last_visit) != box.variant;
  }
  return out;
}

std::string movers_json(const std::vector<MoverBox>& movers) {
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const MoverBox& m : movers) {
    nlohmann::ordered_json j;
    j["id"] = m.movable_id;
    j["variant"] = m.variant;
    j["min"] = {m.min.x(), m.min.y(), m.min.z()};
    j["max"] = {m.max.x(), m.max.y(), m.max.z()};
    j["left"] = m.left;
    list.push_back(j);
  }
  nlohmann::ordered_json doc;
  doc["format"] = "loopd-movers";
  doc["version"] = 1;
  doc["movers"] = list;
  return doc.dump();
}

}  // namespace loopd
