#pragma once
/// @file The one voxel grid of loopd: packed 21-bit voxel keys, an open-addressing table from key to voxel, double sums
/// accumulated in point index order, voxels sorted by key. voxel_downsample (base/cloud_ops) and prepare_scan's fused
/// crop + downsample (pipeline/prepare_scan) both use it, so they give the same centroids in the same order.
#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace loopd {

namespace detail {
/// @brief Slot of a packed voxel key (x << 42 | y << 21 | z) in an open-addressing table of `capacity` (a power of
/// two) slots. Every key bit reaches the low bits (murmur3's 64-bit finaliser): a plain multiply-and-shift that keeps
/// middle bits ignores x entirely, and whole rows of voxels then share one probe chain.
inline std::size_t voxel_slot(std::uint64_t key, std::size_t capacity) {
  key ^= key >> 33;
  key *= 0xff51afd7ed558ccdULL;
  key ^= key >> 33;
  key *= 0xc4ceb9fe1a85ec53ULL;
  key ^= key >> 33;
  return static_cast<std::size_t>(key) & (capacity - 1);
}

/// @brief floor(v) for |v| < 2^62 (voxel coordinates), without a libm call.
inline std::int64_t floor_to_int(double v) {
  const auto t = static_cast<std::int64_t>(v);
  return t - (static_cast<double>(t) > v ? 1 : 0);
}
}  // namespace detail

/// @brief Largest |p| / leaf per axis that voxel_key accepts as input (its int64 conversion stays defined).
constexpr double kMaxScaledVoxelCoordinate = 4.0e18;

/// @brief Packs the voxel of `p`: floor(p / leaf) per axis, offset by 2^20 into 21 bits each (x << 42 | y << 21 | z).
/// @param inv_leaf 1 / voxel edge [1/m]
/// @return false when a voxel coordinate lies outside [-2^20, 2^20): the point has no voxel.
/// @note `p` must be finite with |p| / leaf <= kMaxScaledVoxelCoordinate per axis (any point within a lidar's range is).
inline bool voxel_key(const Eigen::Vector3f& p, double inv_leaf, std::uint64_t* key) {
  constexpr std::int64_t kOffset = std::int64_t{1} << 20;
  constexpr std::int64_t kLimit = std::int64_t{1} << 21;
  const std::int64_t x = detail::floor_to_int(p.x() * inv_leaf) + kOffset;
  const std::int64_t y = detail::floor_to_int(p.y() * inv_leaf) + kOffset;
  const std::int64_t z = detail::floor_to_int(p.z() * inv_leaf) + kOffset;
  if (x < 0 || y < 0 || z < 0 || x >= kLimit || y >= kLimit || z >= kLimit) return false;
  *key = (static_cast<std::uint64_t>(x) << 42) | (static_cast<std::uint64_t>(y) << 21) | static_cast<std::uint64_t>(z);
  return true;
}

/// @brief Open-addressing table from a voxel key to a dense voxel index (0, 1, 2, ... in first-seen order). Linear
/// probing from detail::voxel_slot; the table doubles when its load factor would pass 1/2.
class VoxelKeyTable {
 public:
  /// @param min_slots initial slot count (rounded up to a power of two, at least 16); the table grows past it.
  explicit VoxelKeyTable(std::size_t min_slots);

  /// @brief Index of `key`; a new key gets index size() and `*inserted` is set true (false otherwise).
  std::uint32_t find_or_insert(std::uint64_t key, bool* inserted) {
    std::size_t h = probe(key);
    if (slot_key_[h] != kEmpty) {
      *inserted = false;
      return slot_index_[h];
    }
    if (2 * (size_ + 1) > slot_key_.size()) {  // keep the load factor <= 1/2
      grow();
      h = probe(key);
    }
    slot_key_[h] = key;
    slot_index_[h] = static_cast<std::uint32_t>(size_);
    *inserted = true;
    return static_cast<std::uint32_t>(size_++);
  }

  /// @brief Index of `key`, or -1 when the table does not hold it (nothing is inserted).
  std::int64_t find(std::uint64_t key) const {
    const std::size_t h = probe(key);
    return slot_key_[h] == kEmpty ? -1 : static_cast<std::int64_t>(slot_index_[h]);
  }

  /// @brief Keys held.
  std::size_t size() const { return size_; }
  /// @brief Slots of the table (a power of two).
  std::size_t capacity() const { return slot_key_.size(); }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  ///< no valid key has all 63 low bits set

  /// Slot holding `key`, or the empty slot where it would go.
  std::size_t probe(std::uint64_t key) const {
    const std::size_t mask = slot_key_.size() - 1;
    std::size_t h = detail::voxel_slot(key, slot_key_.size());
    while (slot_key_[h] != kEmpty && slot_key_[h] != key) h = (h + 1) & mask;
    return h;
  }
  /// Doubles the slots and re-inserts every key with its index.
  void grow();

  std::vector<std::uint64_t> slot_key_;
  std::vector<std::uint32_t> slot_index_;
  std::size_t size_ = 0;
};

/// @brief A voxel grid: per occupied voxel, the double sum and the count of its points, plus a caller's `Payload`
/// (default-constructed when the voxel is first hit) for what else the caller averages.
///
/// Points are accumulated in the order add() is called (the sums are deterministic); sorted_voxels() then orders the
/// voxels by key. Cost O(n) + O(m log m) for m voxels instead of sorting all n points. Consecutive lidar returns
/// usually fall in the same voxel, so the last voxel is remembered and the table probe skipped for them.
template <typename Payload>
class VoxelGrid {
 public:
  /// @brief One occupied voxel.
  struct Voxel {
    std::uint64_t key;    ///< packed voxel coordinates (voxel_key)
    Eigen::Vector3d sum;  ///< [m] sum of its points, in the order they were added
    std::uint32_t count;  ///< points added
    Payload payload;      ///< the caller's per-voxel data

    /// @brief Mean of its points [m].
    Eigen::Vector3f centroid() const { return (sum / static_cast<double>(count)).cast<float>(); }
  };

  /// @param leaf_size [m] voxel edge (> 0)
  /// @param expected_voxels sizes the table (2x slots) and the voxel list; both grow past it when needed
  VoxelGrid(double leaf_size, std::size_t expected_voxels) : inv_leaf_(1.0 / leaf_size), table_(2 * expected_voxels) {
    voxels_.reserve(expected_voxels);
  }

  /// @brief Adds `p` to its voxel (`p` as voxel_key requires: finite, within kMaxScaledVoxelCoordinate voxels).
  /// @return the voxel (valid until the next add), or nullptr when `p` lies outside the key range (see voxel_key).
  Voxel* add(const Eigen::Vector3f& p) {
    std::uint64_t key = 0;
    if (!voxel_key(p, inv_leaf_, &key)) return nullptr;
    if (key != last_key_) {
      bool inserted = false;
      last_index_ = table_.find_or_insert(key, &inserted);
      if (inserted) voxels_.push_back({key, Eigen::Vector3d::Zero(), 0, Payload{}});
      last_key_ = key;
    }
    Voxel& v = voxels_[last_index_];
    v.sum += p.cast<double>();
    ++v.count;
    return &v;
  }

  /// @brief The occupied voxels, sorted by key (a copy; the grid can take more points).
  std::vector<Voxel> sorted_voxels() const& {
    std::vector<Voxel> out = voxels_;
    std::sort(out.begin(), out.end(), [](const Voxel& a, const Voxel& b) { return a.key < b.key; });
    return out;
  }
  /// @brief Occupied voxels so far.
  std::size_t size() const { return voxels_.size(); }

  /// @brief The occupied voxels, sorted by key (consumes the grid).
  std::vector<Voxel> sorted_voxels() && {
    std::sort(voxels_.begin(), voxels_.end(), [](const Voxel& a, const Voxel& b) { return a.key < b.key; });
    return std::move(voxels_);
  }

 private:
  static constexpr std::uint64_t kNoKey = ~std::uint64_t{0};

  double inv_leaf_;
  VoxelKeyTable table_;
  std::vector<Voxel> voxels_;
  std::uint64_t last_key_ = kNoKey;
  std::uint32_t last_index_ = 0;
};

}  // namespace loopd
