#include "loopd/pipeline/keyframe_database.hpp"

namespace loopd {

const KeyframeRecord& KeyframeDatabase::add(KeyframeRecord record) {
  bytes_ += sizeof(KeyframeRecord) + (record.features ? record.features->bytes() : 0);
  slot_of_[record.key] = records_.size();
  records_.push_back(std::move(record));
  return records_.back();
}

const KeyframeRecord* KeyframeDatabase::find(const KeyframeKey& key) const {
  const auto it = slot_of_.find(key);
  return it == slot_of_.end() ? nullptr : &records_[it->second];
}

std::optional<std::size_t> KeyframeDatabase::drop_features(const KeyframeKey& key) {
  const auto it = slot_of_.find(key);
  if (it == slot_of_.end() || !records_[it->second].features) return std::nullopt;
  KeyframeRecord& r = records_[it->second];
  bytes_ -= r.features->bytes();
  r.features.reset();
  return it->second;
}

}  // namespace loopd
