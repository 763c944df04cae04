#pragma once
/// @file How a keyframe is named everywhere in loopd: the session it belongs to and its index in that session.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace loopd {

/// @brief A drive (or a segment of one after an odometry reset) with its own odometry frame. 0 = the first session.
using SessionId = std::int32_t;

/// @brief The name of one keyframe: (session, index), with a 64-bit index counted from 0 in its session.
/// Never a position in some container: code that stores keyframes maps keys to its own slots explicitly.
struct KeyframeKey {
  SessionId session = 0;
  std::int64_t index = 0;

  friend bool operator==(const KeyframeKey& a, const KeyframeKey& b) { return a.session == b.session && a.index == b.index; }
  friend bool operator!=(const KeyframeKey& a, const KeyframeKey& b) { return !(a == b); }
  /// Session first, then index: the order keyframes were made in within one session.
  friend bool operator<(const KeyframeKey& a, const KeyframeKey& b) { return a.session < b.session || (a.session == b.session && a.index < b.index); }
};

/// @brief "session/index", e.g. "0/17" (log lines).
std::string to_string(const KeyframeKey& key);

/// @brief Keyframes made between `older` and `newer` in the same session (newer.index - older.index); keyframes of
/// different sessions have no odometry between them and are "unrelated" (the largest int64).
std::int64_t keyframes_between(const KeyframeKey& older, const KeyframeKey& newer);

/// @brief Hash for unordered containers keyed by KeyframeKey.
struct KeyframeKeyHash {
  std::size_t operator()(const KeyframeKey& key) const noexcept {
    const auto mixed =
        static_cast<std::uint64_t>(key.index) * 0x9E3779B97F4A7C15ULL ^ static_cast<std::uint64_t>(static_cast<std::uint32_t>(key.session));
    return static_cast<std::size_t>(mixed);
  }
};

}  // namespace loopd
