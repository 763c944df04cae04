#pragma once
/// @file One keyframe as loopd keeps it: where odometry put it, and the features loop detection compares.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/information.hpp"
#include "loopd/descriptor/scan_context.hpp"
#include "loopd/records/keyframe_key.hpp"
#include "loopd/records/prepared_scan.hpp"

namespace loopd {

/// @brief What a keyframe's scan yields: the place descriptor (Vlaminck 2019 Sec. 4.1) and the prepared scan for
/// verification (Sec. 4.2-4.3). Computed once, on a worker thread, from the scan alone.
struct KeyframeFeatures {
  bool ok = false;
  std::string error;           ///< why the scan is unusable (ok = false)
  Eigen::VectorXf descriptor;  ///< M2DP signature
  PlaceDescriptor place;       ///< Scan Context (global retrieval; ok = false when not computed)
  /// The same scan's Scan Context seen from points beside the sensor (global retrieval's lateral augmentation; query
  /// only, never stored or indexed).
  std::vector<PlaceDescriptor> place_shifted;
  PreparedScan prepared;           ///< voxel cloud, normals, segmentation
  double ms_descriptor = 0.0;      ///< [ms]
  double ms_prepare = 0.0;         ///< [ms]
  std::size_t input_points = 0;    ///< points in the raw scan
  std::size_t invalid_points = 0;  ///< NaN/Inf points removed
  float scene_scale = 0.f;         ///< [m] scene_scale() of the scan (sizes the travel gap of this keyframe's queries); not stored
  std::string sensor_layout;       ///< what the scan showed of its lidar (SensorEstimate::describe); not stored
  std::string sensor_mismatch;     ///< how the configured preset differs from the scan; empty: it fits (or "auto")
  /// The prepared scan is not held here (`prepared` is empty): it is in the map store and read back on demand.
  bool prepared_in_store = false;

  /// @brief Heap + object footprint [bytes] of the descriptor and the prepared scan.
  std::size_t bytes() const {
    std::size_t b = prepared.bytes() + static_cast<std::size_t>(descriptor.size()) * sizeof(float) + place_bytes(place);
    for (const PlaceDescriptor& p : place_shifted) b += place_bytes(p);
    return b;
  }
  static std::size_t place_bytes(const PlaceDescriptor& p) { return p.bins.size() + (p.ring_key.size() + p.column_norms.size()) * sizeof(float); }
};

/// @brief The step from the previous keyframe of the pose sequence measured by their scans (correction.steps): the
/// corrections use it in place of the odometry's step.
struct MeasuredStep {
  Eigen::Isometry3d T_previous_this = Eigen::Isometry3d::Identity();
  Information6d information = Information6d::Zero();
};

/// @brief A keyframe: its name, its odometry pose and its features (null when it was shed under load: the pose still
/// belongs to the trajectory but the keyframe is neither a query nor a candidate).
struct KeyframeRecord {
  KeyframeKey key;
  std::int64_t utime = 0;  ///< scan time [us]
  Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();
  double residual = 0.0;   ///< odometry residual accumulated since the previous keyframe [m]
  double travelled = 0.0;  ///< [m] odometry path length from the session's first keyframe
  /// scan_fingerprint() of the keyframe's raw scan: with the time and the pose, how a replay resumed on its map knows
  /// the keyframes the map holds from those of another drive with the same times (0: not known, maps before it)
  std::uint64_t scan_fingerprint = 0;
  /// Its step from the previous keyframe as the scans measured it; none where it was not measured (off, the first
  /// keyframe of a session, a keyframe without features, a registration not believed, maps before it).
  std::optional<MeasuredStep> step;
  std::shared_ptr<const KeyframeFeatures> features;
};

}  // namespace loopd
