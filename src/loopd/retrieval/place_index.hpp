#pragma once
/// @file Prior-free place retrieval over Scan Context descriptors (Kim & Kim, IROS 2018, Sec. III-C): an exact k-NN on
/// the rotation-invariant ring keys picks candidates, the shift-minimised column distance ranks them.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <shared_mutex>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "loopd/descriptor/scan_context.hpp"
#include "loopd/records/keyframe_key.hpp"

namespace loopd {

/// @brief How PlaceIndex::query ranks.
struct RetrievalConfig {
  int k = 3;                 ///< candidates returned at most
  int ring_candidates = 50;  ///< nearest ring keys that get the full distance (Kim & Kim 2018 search 1% of the map or 50 keys)
  /// Candidates farther than this (place_distance) are dropped. 0.4 from the 13 real KITTI HDL-64E scans with the
  /// default ScanContextConfig (test_place_discrimination_kitti): revisits score 0.06-0.27 up to 4.3 m apart, 0.22 for the
  /// reverse revisit (2.9 m, 148 deg), 0.34 / 0.37 at 8.6 / 9.5 m; the nearest of 54 different-place pairs 0.35. A loose
  /// gate (retrieval is for recall, geometric verification decides); 13 scans are too few to tune it finer.
  float max_place_distance = 0.4f;

  std::optional<std::string> validate() const;
};

/// @brief One retrieved place.
struct PlaceCandidate {
  KeyframeKey key;
  float ring_key_distance = 0.f;  ///< L2 distance of the ring keys
  float place_distance = 1.f;     ///< shift-minimised Scan Context distance, in [0, 1]
  double yaw_match_query = 0.;    ///< [rad] p_match = Rz(yaw) * p_query (PlaceMatch::yaw_match_query)
};

/// @brief Where a query spent its time (for loopd-bench retrieval).
struct PlaceQueryStats {
  std::size_t accepted = 0;      ///< entries the filter accepted
  std::size_t compared = 0;      ///< entries that got the full distance
  double ring_key_ms = 0.;       ///< filter + ring-key k-NN
  double full_distance_ms = 0.;  ///< full distances + final sort
};

/// @brief Scan Context descriptors of keyframes in flat arrays (ring keys, bins and column norms each one contiguous
/// vector), searched exactly by brute force: 100,000 entries are about 150 MB and a query reads their 8 MB of ring keys.
/// @note query() and the other const methods may run concurrently with each other and with add() (a shared mutex);
///       `accept` is called on the calling thread, with the index's lock held: it must not call add().
class PlaceIndex {
 public:
  /// @brief Adds one keyframe's descriptor. Returns false (and adds nothing) when it is not ok or its shape or
  /// quantisation differ from the first entry's. Keys are not checked for duplicates.
  bool add(const KeyframeKey& key, PlaceDescriptor descriptor);
  /// @brief Takes `key`'s entry out (a retired keyframe: never a place candidate again); the last entry moves into its
  /// slot, so ties among later queries fall by that order. False when the key is not in the index.
  bool remove(const KeyframeKey& key);
  std::size_t size() const;
  /// @brief Bytes held by the entry arrays (capacity, not size).
  std::size_t bytes() const;

  /// @brief The best `config.k` places for `q`, nearest first (place_distance, then key), none above
  /// config.max_place_distance. Entries `accept` rejects are skipped before any distance (empty accept: all).
  /// Exact ring-key k-NN over the accepted entries (ties by insertion order), then place_distance on the
  /// config.ring_candidates nearest. Empty when q is not ok, differs in shape, or config does not validate.
  std::vector<PlaceCandidate> query(const PlaceDescriptor& q, const RetrievalConfig& config,
                                    const std::function<bool(const KeyframeKey&)>& accept = {}, PlaceQueryStats* stats = nullptr) const;
  /// @brief The same for several views of one place (e.g. a scan seen from beside the sensor too): each entry is ranked
  /// at its nearest view, in one pass over the ring keys, and its place_distance is its nearest view's. One view:
  /// exactly query().
  std::vector<PlaceCandidate> query_views(const std::vector<const PlaceDescriptor*>& views, const RetrievalConfig& config,
                                          const std::function<bool(const KeyframeKey&)>& accept = {}, PlaceQueryStats* stats = nullptr) const;
  /// @brief The place distance (nearest view) of the named keyframes, those within max_place_distance, in the order
  /// given (ring_key_distance -1: not compared); keys not in the index are left out.
  std::vector<PlaceCandidate> compare(const std::vector<const PlaceDescriptor*>& views, const std::vector<KeyframeKey>& keys,
                                      float max_place_distance) const;

 private:
  bool compatible(const PlaceDescriptor& d) const;
  bool usable(const PlaceDescriptor& q) const;
  std::vector<std::pair<float, std::size_t>> nearest_ring_keys(const std::vector<const PlaceDescriptor*>& views, std::size_t m,
                                                               const std::function<bool(const KeyframeKey&)>& accept, std::size_t* accepted) const;

  mutable std::shared_mutex mutex_;
  int num_rings_ = 0, num_sectors_ = 0;
  float max_range_ = 0.f, height_offset_ = 0.f, height_step_ = 0.f;
  std::vector<KeyframeKey> keys_;
  std::unordered_map<KeyframeKey, std::size_t, KeyframeKeyHash> slot_of_;  ///< position of each key
  std::vector<float> ring_keys_;                                           ///< size() x num_rings_
  std::vector<std::uint8_t> bins_;                                         ///< size() x (num_sectors_ x num_rings_), sector-major per entry
  std::vector<float> column_norms_;                                        ///< size() x num_sectors_
};

}  // namespace loopd
