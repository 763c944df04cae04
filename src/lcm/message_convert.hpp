#pragma once
#include <cmath>
#include <cstdint>
#include <string>

#include <loopd/point_cloud_t.hpp>
#include <loopd/imu_t.hpp>
#include <loopd/pose_t.hpp>

#include "loopd/base/imu.hpp"
#include "loopd/base/point_cloud.hpp"
#include "loopd/base/pose.hpp"

namespace loopd {

/// @brief Default channel names (all configurable in the daemon and tools).
namespace channels {
inline constexpr const char* kScan = "LIDAR_SCAN";
inline constexpr const char* kPose = "ODOMETRY_POSE";
inline constexpr const char* kGroundTruth = "GROUND_TRUTH_POSE";
inline constexpr const char* kImu = "IMU";
inline constexpr const char* kLoopEvent = "LOOP_EVENT";
inline constexpr const char* kTrajectory = "CORRECTED_TRAJECTORY";
inline constexpr const char* kStatus = "LOOPD_STATUS";
}  // namespace channels

/// @brief Most rings a scan may declare (lidars have at most 128 beams; the range image has one row per ring).
inline constexpr int kMaxRings = 512;
/// @brief Largest odometry position accepted [m]: anything beyond is a corrupt pose, not a place on Earth.
inline constexpr double kMaxPosition = 1e7;

/// @brief Largest |time_offset| of a point accepted [s]: a sweep lasts 0.05-0.2 s (5-20 Hz); anything beyond a second
/// is a stamp from another clock, not a time within the sweep.
inline constexpr double kMaxPointTimeOffset = 1.0;

/// @brief Per-point times go out when the cloud has them (num_point_times = num_points), else num_point_times = 0.
point_cloud_t to_message(const PointCloud& cloud, std::int64_t utime, std::int64_t seq, const std::string& frame);
/// @brief point_cloud_t's content rules, one function each, shared by from_message and decode_scan so both refuse the
/// same scans with the same words. Each is empty when the rule holds, else the reason.
/// num_ring_indices is 0 (no rings) or num_points.
std::string ring_indices_error(std::int64_t num_points, std::int64_t num_ring_indices);
/// num_rings within 0..kMaxRings.
std::string num_rings_error(std::int64_t num_rings);
/// A per-point time offset is finite and within kMaxPointTimeOffset of the stamp (inline: it runs for every point).
inline bool point_time_ok(float time_offset) { return std::abs(time_offset) <= kMaxPointTimeOffset; }  // NaN fails
/// Why `time_offset` fails point_time_ok.
std::string point_time_error(float time_offset);

/// @brief Validates array sizes and per-point times (finite, within kMaxPointTimeOffset); NaN points are kept (the
/// pipeline filters and counts them). Times fill cloud->time when the message has them.
bool from_message(const point_cloud_t& msg, PointCloud* cloud, std::string* error);

pose_t to_message(const StampedPose& pose, std::int64_t seq);
/// @brief Rejects non-finite numbers, positions beyond kMaxPosition and a zero quaternion.
bool from_message(const pose_t& msg, StampedPose* pose, std::string* error);

/// Largest turn rate loopd accepts in an imu_t [rad/s] (a gyro's range is a few thousand deg/s).
inline constexpr double kMaxTurnRate = 100.0;
imu_t to_message(const ImuSample& sample, std::int64_t seq);
/// @brief Rejects a non-finite turn rate or one beyond kMaxTurnRate (the accelerometer is not read).
bool from_message(const imu_t& msg, ImuSample* sample, std::string* error);

}  // namespace loopd
