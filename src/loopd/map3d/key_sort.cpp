#include "loopd/map3d/key_sort.hpp"

#include <algorithm>
#include <cstddef>
#include <utility>

namespace loopd {
namespace {

constexpr int kDigitBits = 16;
constexpr int kKeyBits = 48;
constexpr std::size_t kBuckets = std::size_t{1} << kDigitBits;
constexpr std::size_t kRadixFrom = 4096;  // below this std::sort is as fast (the three histograms cost 1.5 MiB to clear)

void radix_sort(std::vector<std::uint64_t>* v) {
  std::vector<std::uint64_t> scratch(v->size());
  std::vector<std::size_t> start(kBuckets);
  for (int shift = 0; shift < kKeyBits; shift += kDigitBits) {
    std::fill(start.begin(), start.end(), 0);
    for (std::uint64_t k : *v) ++start[(k >> shift) & (kBuckets - 1)];
    std::size_t sum = 0;
    for (std::size_t& c : start) sum += std::exchange(c, sum);
    for (std::uint64_t k : *v) scratch[start[(k >> shift) & (kBuckets - 1)]++] = k;
    v->swap(scratch);
  }
}

}  // namespace

void sort_unique_keys(std::vector<std::uint64_t>* keys) {
  if (keys->size() < kRadixFrom)
    std::sort(keys->begin(), keys->end());
  else
    radix_sort(keys);
  keys->erase(std::unique(keys->begin(), keys->end()), keys->end());
}

}  // namespace loopd
