// DescriptorStore: exact k-nearest search by a flat scan with partial-distance early-out.
// On 192-D M2DP descriptors a k-d tree prunes almost nothing (the curse of dimensionality), while the
// flat scan streams contiguous floats and stops a row as soon as its partial sum exceeds the k-th best.
#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

#include "loopd/descriptor/m2dp.hpp"

namespace loopd {

namespace {
/// Dimensions summed between early-out checks.
constexpr int kBlock = 16;
}  // namespace

void DescriptorStore::add(std::int64_t id, const Eigen::VectorXf& descriptor) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (ids_.empty() && dim_ == 0) dim_ = static_cast<int>(descriptor.size());
  if (descriptor.size() != dim_ || dim_ == 0) return;  // wrong size: ignored (descriptors of one config only)
  ids_.push_back(id);
  data_.insert(data_.end(), descriptor.data(), descriptor.data() + dim_);
}

std::size_t DescriptorStore::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return ids_.size();
}

std::vector<std::pair<std::int64_t, float>> DescriptorStore::knn(const Eigen::VectorXf& query, int k,
                                                                 const std::function<bool(std::int64_t)>& filter) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::pair<std::int64_t, float>> out;
  if (k <= 0 || query.size() != dim_ || ids_.empty()) return out;
  const float* q = query.data();
  // Max-heap of (squared distance, row) holding the best k so far.
  std::priority_queue<std::pair<float, std::size_t>> heap;
  float bound = std::numeric_limits<float>::infinity();
  const std::size_t rows = ids_.size();
  for (std::size_t r = 0; r < rows; ++r) {
    const float* x = data_.data() + r * static_cast<std::size_t>(dim_);
    float d2 = 0.0f;
    int j = 0;
    for (; j + kBlock <= dim_; j += kBlock) {
      for (int b = 0; b < kBlock; ++b) {
        const float t = x[j + b] - q[j + b];
        d2 += t * t;
      }
      if (d2 >= bound) break;
    }
    if (d2 >= bound) continue;
    for (; j < dim_; ++j) {
      const float t = x[j] - q[j];
      d2 += t * t;
    }
    if (d2 >= bound) continue;
    if (filter && !filter(ids_[r])) continue;
    heap.emplace(d2, r);
    if (static_cast<int>(heap.size()) > k) heap.pop();
    if (static_cast<int>(heap.size()) == k) bound = heap.top().first;
  }
  out.resize(heap.size());
  for (std::size_t i = out.size(); i-- > 0;) {
    out[i] = {ids_[heap.top().second], std::sqrt(heap.top().first)};
    heap.pop();
  }
  return out;
}

}  // namespace loopd
