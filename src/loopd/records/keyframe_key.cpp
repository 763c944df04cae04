#include "loopd/records/keyframe_key.hpp"

#include <limits>

namespace loopd {

std::string to_string(const KeyframeKey& key) { return std::to_string(key.session) + "/" + std::to_string(key.index); }

std::int64_t keyframes_between(const KeyframeKey& older, const KeyframeKey& newer) {
  if (older.session != newer.session) return std::numeric_limits<std::int64_t>::max();
  return newer.index - older.index;
}

}  // namespace loopd
