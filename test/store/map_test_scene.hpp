#pragma once
// Shared by the map tests: keyframe features from a real simulated HDL-64E scan (segmentation of the cropped scan,
// its range-image normals, a stride sample of the points as the voxel cloud), and exact (bit-level) comparisons.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <memory>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/records/keyframe_record.hpp"
#include "loopd/segmentation/segmentation.hpp"
#include "loopd/sim/drive.hpp"

namespace loopd::map_test {

/// @brief A 30-scan HDL-64E drive through the town (seed 5).
inline const Drive& town_drive() {
  static const Drive drive = [] {
    DriveConfig dc;
    dc.sensor = "hdl64";
    dc.num_scans = 30;
    dc.seed = 5;
    return make_drive(dc);
  }();
  return drive;
}

inline PackedNormal pack(const Eigen::Vector3f& n) {
  return {static_cast<std::int8_t>(std::lround(127.f * n.x())), static_cast<std::int8_t>(std::lround(127.f * n.y())),
          static_cast<std::int8_t>(std::lround(127.f * n.z()))};
}

/// @brief Features of scan `i` of town_drive(): real points, normals (some zero), clusters with hulls, timings.
inline std::shared_ptr<const KeyframeFeatures> scan_features(int i) {
  const Drive& drive = town_drive();
  const PointCloud scan = drive.simulate(i, 2);
  const PointCloud cropped = crop_range(scan, 2.0, 60.0);
  std::vector<Eigen::Vector3f> normals;
  auto f = std::make_shared<KeyframeFeatures>();
  f->prepared.segmentation = segment(cropped, &drive.model, SegmentationConfig{}, &normals);
  const std::size_t stride = cropped.size() / 6000 + 1;
  for (std::size_t k = 0; k < cropped.size(); k += stride) {
    f->prepared.points.push_back(cropped.points[k]);
    f->prepared.normals.push_back(pack(normals[k]));
  }
  f->prepared.input_points = scan.size();
  f->prepared.finite_points = scan.size();
  f->prepared.ms_segmentation = f->prepared.segmentation.ms;
  f->prepared.ms_total = f->prepared.segmentation.ms * 1.37;
  // A 192-value signature (M2DP's size) from the scan: azimuth histogram weighted by range.
  f->descriptor = Eigen::VectorXf::Zero(192);
  for (const auto& p : cropped.points) {
    const double az = std::atan2(p.y(), p.x()) + M_PI;
    f->descriptor[static_cast<Eigen::Index>(std::min(191.0, az / (2 * M_PI) * 192.0))] += p.norm() / static_cast<float>(cropped.size());
  }
  f->ok = true;
  f->ms_descriptor = 3.25 + 0.001 * i;
  f->ms_prepare = f->prepared.ms_total;
  f->input_points = scan.size();
  f->invalid_points = static_cast<std::size_t>(i);
  return f;
}

template <typename T>
bool same_bits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

inline bool same_points(const std::vector<Eigen::Vector3f>& a, const std::vector<Eigen::Vector3f>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(Eigen::Vector3f)) == 0);
}

inline void require_same_prepared(const PreparedScan& a, const PreparedScan& b) {
  REQUIRE(same_points(a.points, b.points));
  REQUIRE(a.normals.size() == b.normals.size());
  for (std::size_t i = 0; i < a.normals.size(); ++i) {
    REQUIRE(a.normals[i].x == b.normals[i].x);
    REQUIRE(a.normals[i].y == b.normals[i].y);
    REQUIRE(a.normals[i].z == b.normals[i].z);
  }
  CHECK(a.input_points == b.input_points);
  CHECK(a.finite_points == b.finite_points);
  CHECK(same_bits(a.ms_segmentation, b.ms_segmentation));
  CHECK(same_bits(a.ms_total, b.ms_total));
  CHECK(a.error == b.error);
  CHECK(a.segmentation.error == b.segmentation.error);
  CHECK(same_bits(a.segmentation.ms, b.segmentation.ms));
  REQUIRE(a.segmentation.clusters.size() == b.segmentation.clusters.size());
  for (std::size_t i = 0; i < a.segmentation.clusters.size(); ++i) {
    const Cluster &x = a.segmentation.clusters[i], &y = b.segmentation.clusters[i];
    INFO("cluster " << i);
    CHECK(std::memcmp(x.centroid.data(), y.centroid.data(), sizeof(float) * 3) == 0);
    CHECK(x.num_points == y.num_points);
    CHECK(x.planar == y.planar);
    CHECK(std::memcmp(x.plane.data(), y.plane.data(), sizeof(float) * 4) == 0);
    CHECK(same_points(x.points, y.points));
    CHECK(same_points(x.hull, y.hull));
    CHECK(same_bits(x.extent_major, y.extent_major));
    CHECK(same_bits(x.extent_minor, y.extent_minor));
  }
}

inline bool same_descriptor(const Eigen::VectorXf& a, const Eigen::VectorXf& b) {
  return a.size() == b.size() && (a.size() == 0 || std::memcmp(a.data(), b.data(), static_cast<std::size_t>(a.size()) * sizeof(float)) == 0);
}

/// @brief Everything but the prepared scan (checked by require_same_prepared).
inline void require_same_feature_fields(const KeyframeFeatures& a, const KeyframeFeatures& b) {
  CHECK(a.ok == b.ok);
  CHECK(a.error == b.error);
  CHECK(same_descriptor(a.descriptor, b.descriptor));
  CHECK(same_bits(a.ms_descriptor, b.ms_descriptor));
  CHECK(same_bits(a.ms_prepare, b.ms_prepare));
  CHECK(a.input_points == b.input_points);
  CHECK(a.invalid_points == b.invalid_points);
}

inline bool same_pose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return std::memcmp(a.matrix().data(), b.matrix().data(), 16 * sizeof(double)) == 0;
}

}  // namespace loopd::map_test
