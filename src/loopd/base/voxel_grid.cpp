#include "loopd/base/voxel_grid.hpp"

namespace loopd {

VoxelKeyTable::VoxelKeyTable(std::size_t min_slots) {
  std::size_t capacity = 16;
  while (capacity < min_slots) capacity <<= 1;
  slot_key_.assign(capacity, kEmpty);
  slot_index_.resize(capacity);
}

void VoxelKeyTable::grow() {
  std::vector<std::uint64_t> old_key(2 * slot_key_.size(), kEmpty);
  std::vector<std::uint32_t> old_index(old_key.size());
  old_key.swap(slot_key_);
  old_index.swap(slot_index_);
  for (std::size_t s = 0; s < old_key.size(); ++s) {
    if (old_key[s] == kEmpty) continue;
    const std::size_t h = probe(old_key[s]);
    slot_key_[h] = old_key[s];
    slot_index_[h] = old_index[s];
  }
}

}  // namespace loopd
