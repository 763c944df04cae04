#pragma once
/// @file How both map back ends store poses, keys and arrays of numbers in blobs: raw little-endian doubles and
/// integers (a map is read on the machine that wrote it or another x86/ARM little-endian one).
#include <Eigen/Geometry>
#include <cstdint>
#include <cstring>
#include <vector>

#include "loopd/records/keyframe_key.hpp"
#include "loopd/records/keyframe_record.hpp"

namespace loopd::blobs {

inline constexpr std::size_t kPoseBytes = 12 * sizeof(double);
inline constexpr std::size_t kKeyBytes = 4 + 8;  // session int32, index int64

inline void append_bytes(std::vector<std::uint8_t>& out, const void* v, std::size_t n) {
  const std::size_t at = out.size();
  out.resize(at + n);
  std::memcpy(out.data() + at, v, n);
}
inline void append_doubles(std::vector<std::uint8_t>& out, const double* v, std::size_t n) { append_bytes(out, v, n * sizeof(double)); }

/// @brief An isometry as 12 doubles (the 3x4 matrix, column-major): bit-exact, unlike a quaternion.
inline void append_pose(std::vector<std::uint8_t>& out, const Eigen::Isometry3d& T) {
  const Eigen::Matrix<double, 3, 4> top = T.matrix().topRows<3>();
  append_doubles(out, top.data(), 12);
}
inline std::vector<std::uint8_t> pose_blob(const Eigen::Isometry3d& T) {
  std::vector<std::uint8_t> out;
  append_pose(out, T);
  return out;
}
inline Eigen::Isometry3d read_pose(const std::uint8_t* p) {
  Eigen::Matrix<double, 3, 4> top;
  std::memcpy(top.data(), p, kPoseBytes);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix().topRows<3>() = top;
  return T;
}
inline void append_key(std::vector<std::uint8_t>& out, const KeyframeKey& key) {
  append_bytes(out, &key.session, 4);
  append_bytes(out, &key.index, 8);
}
inline KeyframeKey read_key(const std::uint8_t* p) {
  KeyframeKey key;
  std::memcpy(&key.session, p, 4);
  std::memcpy(&key.index, p + 4, 8);
  return key;
}

/// @brief A measured keyframe step: the pose (12 doubles) and its information (36 doubles, column-major).
inline constexpr std::size_t kStepBytes = kPoseBytes + 36 * sizeof(double);
inline std::vector<std::uint8_t> step_blob(const MeasuredStep& step) {
  std::vector<std::uint8_t> out = pose_blob(step.T_previous_this);
  append_doubles(out, step.information.data(), 36);
  return out;
}
/// @brief The step of a blob of kStepBytes (the caller checks the size).
inline MeasuredStep read_step(const std::uint8_t* p) {
  MeasuredStep step;
  step.T_previous_this = read_pose(p);
  std::memcpy(step.information.data(), p + kPoseBytes, 36 * sizeof(double));
  return step;
}

}  // namespace loopd::blobs
