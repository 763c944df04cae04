#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

#include <loopd/channel_stats_t.hpp>
#include <loopd/imu_t.hpp>
#include <loopd/keyframe_pose_t.hpp>
#include <loopd/loop_event_t.hpp>
#include <loopd/point_cloud_t.hpp>
#include <loopd/pose_t.hpp>
#include <loopd/session_alignment_t.hpp>
#include <loopd/localization_t.hpp>
#include <loopd/status_t.hpp>
#include <loopd/trajectory_t.hpp>

namespace loopd {

/// @brief Caps applied to a message's declared lengths before anything is allocated.
struct DecodeLimits {
  std::int64_t max_points = 2000000;      ///< point_cloud_t.num_points and num_ring_indices (num_point_times: 0 or num_points)
  std::int32_t max_string = 4096;         ///< bytes of one string (frame, stage, reason, channel, method, device)
  std::int32_t max_channels = 1024;       ///< status_t.num_channels
  std::int64_t max_keyframes = 10000000;  ///< trajectory_t.num_keyframes
  std::int64_t max_sessions = 100000;     ///< trajectory_t.num_sessions
};

/// @brief Outcome of a bounded decode: ok, or the reason and the byte offset where the message went wrong.
struct DecodeResult {
  bool ok = false;
  std::string reason;      ///< empty when ok, e.g. "num_points = -1 is negative"
  std::size_t offset = 0;  ///< byte offset of the field that failed
  explicit operator bool() const { return ok; }
};

/// @brief Decodes an lcm-gen message from untrusted bytes. LCM's generated decoder resizes every variable-length
///        array and string to its declared length before it checks that the bytes are there (a 60-byte message can
///        ask for gigabytes, and a length of -1 throws std::length_error). This first walks the wire format of `Msg`,
///        checking the fingerprint, every declared length against the bytes present and against `limits`, and that
///        nothing trails the message; only then does it run LCM's decoder (inside a try block). Never throws.
///        Supported: point_cloud_t, pose_t, imu_t, loop_event_t, trajectory_t, status_t, keyframe_pose_t, channel_stats_t,
///        session_alignment_t, localization_t.
template <typename Msg>
DecodeResult decode_bounded(const void* data, std::size_t size, const DecodeLimits& limits, Msg* out);

/// @brief Decodes a trajectory_t of version 1 (the layout before `full` and `total_keyframes` were appended, in
///        output logs of older loopd builds; its own fingerprint) with the same checks, as today's trajectory_t with
///        full = true and total_keyframes = num_keyframes (version 1 always held every keyframe).
DecodeResult decode_trajectory_v1(const void* data, std::size_t size, const DecodeLimits& limits, trajectory_t* out);

/// @brief Decodes a trajectory_t of version 2 (before the sessions were appended: keyframe_sessions, sessions) as
///        today's trajectory_t with every keyframe in session 0 and no session alignments.
DecodeResult decode_trajectory_v2(const void* data, std::size_t size, const DecodeLimits& limits, trajectory_t* out);

/// @brief Decodes a loop_event_t of either layout: version 1 (before query_session, match_session, retrieval and
///        place_distance) as sessions 0 / 0, retrieval "gate", place_distance -1; otherwise decode_bounded.
DecodeResult decode_any_loop_event(const void* data, std::size_t size, const DecodeLimits& limits, loop_event_t* out);

/// @brief Fingerprint of point_cloud_t version 1: the layout before `num_point_times` and `time_offset` were appended
///        (drive logs and live publishers of older builds).
inline constexpr std::int64_t kPointCloudV1Hash = 0x3cbfda035faafa31LL;

/// @brief Decodes a point_cloud_t of version 1 (see kPointCloudV1Hash) with the same checks, as today's point_cloud_t
///        with num_point_times = 0 (no per-point times).
DecodeResult decode_point_cloud_v1(const void* data, std::size_t size, const DecodeLimits& limits, point_cloud_t* out);

/// @brief Decodes a point_cloud_t of either layout, chosen by its fingerprint: decode_point_cloud_v1 for version 1,
///        decode_bounded otherwise (whose reason then names a wrong fingerprint). What every scan reader uses.
DecodeResult decode_any_point_cloud(const void* data, std::size_t size, const DecodeLimits& limits, point_cloud_t* out);

}  // namespace loopd
