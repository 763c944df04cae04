// DescriptorStore: exact k-nearest search by a flat scan with partial-distance early-out.
// On 192-D M2DP descriptors a k-d tree prunes almost nothing (the curse of dimensionality), while the
// flat scan streams contiguous floats and stops a row as soon as its partial sum exceeds the k-th best.
#include <algorithm>
#include <cmath>
#include <limits>
#include <omp.h>
#include <vector>

#include "loopd/descriptor/m2dp.hpp"

namespace loopd {

namespace {
/// Dimensions summed between early-out checks.
constexpr int kBlock = 32;
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

namespace {

/// Squared L2 distance of one row, summed in kBlock-wide blocks (vectorised) with an early out once the partial sum
/// reaches `bound` (the current k-th best); returns a value >= bound when cut short.
inline float row_distance2(const float* __restrict x, const float* __restrict q, int dim, float bound) {
  float d2 = 0.0f;
  int j = 0;
  for (; j + kBlock <= dim; j += kBlock) {
    float part = 0.0f;
    for (int b = 0; b < kBlock; ++b) {
      const float t = x[j + b] - q[j + b];
      part += t * t;
    }
    d2 += part;
    if (d2 >= bound) return d2;
  }
  for (; j < dim; ++j) {
    const float t = x[j] - q[j];
    d2 += t * t;
  }
  return d2;
}

/// Best-k list (max-heap on squared distance) of one thread.
struct TopK {
  explicit TopK(int k) : k(k) {}
  int k;
  std::vector<std::pair<float, std::size_t>> heap;
  float bound = std::numeric_limits<float>::infinity();
  void push(float d2, std::size_t row) {
    if (d2 >= bound) return;
    heap.emplace_back(d2, row);
    std::push_heap(heap.begin(), heap.end());
    if (static_cast<int>(heap.size()) > k) {
      std::pop_heap(heap.begin(), heap.end());
      heap.pop_back();
    }
    if (static_cast<int>(heap.size()) == k) bound = heap.front().first;
  }
};

}  // namespace

std::vector<std::pair<std::int64_t, float>> DescriptorStore::knn(const Eigen::VectorXf& query, int k,
                                                                 const std::function<bool(std::int64_t)>& filter) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::pair<std::int64_t, float>> out;
  if (k <= 0 || query.size() != dim_ || ids_.empty()) return out;
  const float* q = query.data();
  const std::size_t rows = ids_.size();
  const int dim = dim_;
  // Exact search: contiguous row-major floats streamed by all threads (each a contiguous range of rows with its own
  // best-k list and early-out bound), rows rejected by the filter skipped before their floats are read; the lists
  // are merged at the end. Small stores run on one thread (thread start-up would dominate).
  const int threads = rows >= 4096 ? std::max(1, omp_get_max_threads()) : 1;
  std::vector<TopK> lists(static_cast<std::size_t>(threads), TopK(k));
#pragma omp parallel num_threads(threads)
  {
    TopK& best = lists[static_cast<std::size_t>(omp_get_thread_num())];
#pragma omp for schedule(static)
    for (std::int64_t r = 0; r < static_cast<std::int64_t>(rows); ++r) {
      if (filter && !filter(ids_[static_cast<std::size_t>(r)])) continue;
      const float d2 = row_distance2(data_.data() + static_cast<std::size_t>(r) * dim, q, dim, best.bound);
      best.push(d2, static_cast<std::size_t>(r));
    }
  }
  std::vector<std::pair<float, std::size_t>> all;
  for (const TopK& t : lists) all.insert(all.end(), t.heap.begin(), t.heap.end());
  // Ties broken by insertion order, so the result does not depend on the number of threads.
  std::sort(all.begin(), all.end());
  if (static_cast<int>(all.size()) > k) all.resize(static_cast<std::size_t>(k));
  out.reserve(all.size());
  for (const auto& [d2, r] : all) out.emplace_back(ids_[r], std::sqrt(d2));
  return out;
}

}  // namespace loopd
