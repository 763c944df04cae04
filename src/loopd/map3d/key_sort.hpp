#pragma once
/// @file Sorting the octree leaf keys of a scan's rays: hundreds of thousands of packed 48-bit keys per scan and
/// thread, which std::sort took a fifth of a map export to order.
#include <cstdint>
#include <vector>

namespace loopd {

/// @brief Sorts `keys` ascending and removes repeats. Keys must fit in 48 bits (three 16-bit octree coordinates);
/// larger inputs are sorted by three 16-bit counting passes, least significant first (the order std::sort gives).
void sort_unique_keys(std::vector<std::uint64_t>* keys);

}  // namespace loopd
