#pragma once
/// @file The keyframes a detector holds in memory, by key, in the order they were added.
#include <cstddef>
#include <optional>
#include <unordered_map>
#include <vector>

#include "loopd/records/keyframe_record.hpp"

namespace loopd {

/// @brief Keyframe records by KeyframeKey, kept in insertion order, with the memory they hold.
/// Not thread-safe: the detector's sequential stage owns it.
class KeyframeDatabase {
 public:
  /// @brief Adds a record (its key must be new) and returns the stored copy.
  const KeyframeRecord& add(KeyframeRecord record);
  /// @brief The record of `key`, or null when there is none.
  const KeyframeRecord* find(const KeyframeKey& key) const;
  /// @brief Drops the features of `key`'s record (a retired keyframe: its pose stays, it is never a candidate again)
  /// and returns where the record is in records(); nullopt when there is no such record or it has no features.
  std::optional<std::size_t> drop_features(const KeyframeKey& key);
  /// @brief Every record, in the order added.
  const std::vector<KeyframeRecord>& records() const { return records_; }
  std::size_t size() const { return records_.size(); }
  bool empty() const { return records_.empty(); }
  const KeyframeRecord& newest() const { return records_.back(); }
  /// @brief Average bytes held per keyframe (record, descriptor, prepared scan); 0 when empty.
  std::size_t bytes_per_keyframe() const { return records_.empty() ? 0 : bytes_ / records_.size(); }

 private:
  std::vector<KeyframeRecord> records_;
  std::unordered_map<KeyframeKey, std::size_t, KeyframeKeyHash> slot_of_;
  std::size_t bytes_ = 0;
};

}  // namespace loopd
