#include "loopd/store/postgres/fleet_correction_blobs.hpp"

#include <cstring>

#include "loopd/store/record_blobs.hpp"

namespace loopd::postgres {
namespace {

constexpr std::size_t kUtimeBytes = 8;
constexpr std::size_t kSessionBytes = 4 + 1 + blobs::kPoseBytes + 8;

void append_session(std::vector<std::uint8_t>& out, const FleetCorrectionRecord::Session& s) {
  blobs::append_bytes(out, &s.id, 4);
  const std::uint8_t anchored = s.anchored ? 1 : 0;
  blobs::append_bytes(out, &anchored, 1);
  blobs::append_pose(out, s.T_map_session);
  blobs::append_bytes(out, &s.keyframes, 8);
}

FleetCorrectionRecord::Session read_session(const std::uint8_t* p) {
  FleetCorrectionRecord::Session s;
  std::memcpy(&s.id, p, 4);
  s.anchored = p[4] != 0;
  s.T_map_session = blobs::read_pose(p + 5);
  std::memcpy(&s.keyframes, p + 5 + blobs::kPoseBytes, 8);
  return s;
}

}  // namespace

std::optional<FleetCorrectionBlobs> encode_fleet_correction(const FleetCorrectionRecord& c) {
  if (c.T_map_sensor.size() != c.keys.size() || c.utimes.size() != c.keys.size()) return std::nullopt;
  FleetCorrectionBlobs out;
  for (std::size_t i = 0; i < c.keys.size(); ++i) {
    blobs::append_key(out.keys, c.keys[i]);
    blobs::append_pose(out.poses, c.T_map_sensor[i]);
    blobs::append_bytes(out.utimes, &c.utimes[i], kUtimeBytes);
  }
  for (const FleetCorrectionRecord::Session& s : c.sessions) append_session(out.sessions, s);
  return out;
}

std::optional<std::string> decode_fleet_correction(const FleetCorrectionBlobs& b, FleetCorrectionRecord& c) {
  const std::size_t n = b.keys.size() / blobs::kKeyBytes;
  if (b.keys.size() % blobs::kKeyBytes != 0 || b.poses.size() != n * blobs::kPoseBytes || b.utimes.size() != n * kUtimeBytes)
    return "keys, poses and scan times of " + std::to_string(b.keys.size()) + ", " + std::to_string(b.poses.size()) + " and " +
           std::to_string(b.utimes.size()) + " bytes do not fit together";
  if (b.sessions.size() % kSessionBytes != 0) return "sessions of " + std::to_string(b.sessions.size()) + " bytes";
  for (std::size_t i = 0; i < n; ++i) {
    c.keys.push_back(blobs::read_key(b.keys.data() + i * blobs::kKeyBytes));
    c.T_map_sensor.push_back(blobs::read_pose(b.poses.data() + i * blobs::kPoseBytes));
    std::int64_t utime = 0;
    std::memcpy(&utime, b.utimes.data() + i * kUtimeBytes, kUtimeBytes);
    c.utimes.push_back(utime);
  }
  for (std::size_t at = 0; at < b.sessions.size(); at += kSessionBytes) c.sessions.push_back(read_session(b.sessions.data() + at));
  return std::nullopt;
}

}  // namespace loopd::postgres
