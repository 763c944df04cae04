#pragma once
/// @file A bounded, least-recently-used cache of keyframe features (the verification data that dominates memory).
#include <cstddef>
#include <list>
#include <memory>
#include <unordered_map>

#include "loopd/records/keyframe_record.hpp"

namespace loopd {

/// @brief Full keyframe features by key, at most `capacity_bytes` of them (KeyframeFeatures::bytes()); the least
/// recently used go first. A feature set handed out stays valid while its holder keeps it, evicted or not.
class FeatureCache {
 public:
  explicit FeatureCache(std::size_t capacity_bytes) : capacity_(capacity_bytes) {}

  /// @brief The features of `key`, now the most recently used; null when not cached.
  std::shared_ptr<const KeyframeFeatures> get(const KeyframeKey& key);
  /// @brief Adds (or replaces) the features of `key` and evicts the least recently used beyond the capacity (the
  /// newest entry itself stays, even when it alone is larger).
  void put(const KeyframeKey& key, std::shared_ptr<const KeyframeFeatures> features);
  /// @brief Drops the features of `key` (a retired keyframe); false when they were not cached.
  bool erase(const KeyframeKey& key);
  std::size_t bytes() const { return bytes_; }
  std::size_t size() const { return index_.size(); }
  std::size_t capacity_bytes() const { return capacity_; }

 private:
  struct Entry {
    KeyframeKey key;
    std::shared_ptr<const KeyframeFeatures> features;
    std::size_t bytes = 0;
  };
  void evict();

  std::size_t capacity_;
  std::size_t bytes_ = 0;
  std::list<Entry> order_;  ///< most recently used first
  std::unordered_map<KeyframeKey, std::list<Entry>::iterator, KeyframeKeyHash> index_;
};

}  // namespace loopd
