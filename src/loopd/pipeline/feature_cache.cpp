#include "loopd/pipeline/feature_cache.hpp"

namespace loopd {

std::shared_ptr<const KeyframeFeatures> FeatureCache::get(const KeyframeKey& key) {
  const auto it = index_.find(key);
  if (it == index_.end()) return nullptr;
  order_.splice(order_.begin(), order_, it->second);
  return it->second->features;
}

void FeatureCache::put(const KeyframeKey& key, std::shared_ptr<const KeyframeFeatures> features) {
  const auto it = index_.find(key);
  if (it != index_.end()) {
    bytes_ -= it->second->bytes;
    order_.erase(it->second);
    index_.erase(it);
  }
  const std::size_t bytes = features ? features->bytes() : 0;
  order_.push_front(Entry{key, std::move(features), bytes});
  index_[key] = order_.begin();
  bytes_ += bytes;
  evict();
}

bool FeatureCache::erase(const KeyframeKey& key) {
  const auto it = index_.find(key);
  if (it == index_.end()) return false;
  bytes_ -= it->second->bytes;
  order_.erase(it->second);
  index_.erase(it);
  return true;
}

void FeatureCache::evict() {
  while (bytes_ > capacity_ && order_.size() > 1) {
    const Entry& last = order_.back();
    bytes_ -= last.bytes;
    index_.erase(last.key);
    order_.pop_back();
  }
}

}  // namespace loopd
