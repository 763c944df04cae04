#include "loopd/records/prepared_scan.hpp"

namespace loopd {

std::size_t PreparedScan::bytes() const {
  return sizeof(PreparedScan) + points.capacity() * sizeof(Eigen::Vector3f) + normals.capacity() * sizeof(PackedNormal) + error.capacity() +
         segmentation.bytes() - sizeof(Segmentation);
}

std::vector<Eigen::Vector3f> PreparedScan::unpacked_normals() const {
  std::vector<Eigen::Vector3f> out;
  if (normals.size() != points.size()) return out;
  out.reserve(normals.size());
  for (const auto& n : normals) {
    const Eigen::Vector3f v(n.x, n.y, n.z);
    const float len = v.norm();
    out.push_back(len > 0.f ? Eigen::Vector3f(v / len) : Eigen::Vector3f::Zero());
  }
  return out;
}

}  // namespace loopd
