#include "loopd/pipeline/remote_keyframes.hpp"

namespace loopd {

const std::optional<RemoteKeyframes::Placement>& RemoteKeyframes::placement(SessionId session) const {
  static const std::optional<Placement> kNone;
  const auto it = sessions_.find(session);
  return it == sessions_.end() ? kNone : it->second;
}

}  // namespace loopd
