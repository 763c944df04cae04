#pragma once
/// @file What the live page shows (--http, loopd-map serve): the keyframes with their odometry and corrected poses,
/// every loop decision with its scores, the newest keyframes' clouds and the health figures. The engine's results go
/// in (one call each, cheap: a mutex and an append); each page's sender reads what it has not had yet, in messages of a
/// bounded size (next_message), so a page that connects late or falls behind catches up without a copy per client.
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "loopd/records/keyframe_key.hpp"
#include "loopd/records/loop_decision.hpp"

namespace loopd {

/// @brief What the feed keeps.
struct ViewFeedConfig {
  int max_rejected = 20000;  ///< rejected decisions kept, the newest (accepted loops are all kept); the funnel counts all
  int clouds = 40;           ///< keyframe clouds kept: the newest, the map near the vehicle
  int cloud_points = 1200;   ///< points per keyframe cloud, evenly decimated
  double moved_m = 0.02;     ///< [m] a corrected pose that moved less than this ...
  double moved_deg = 0.2;    ///< [deg] ... and turned less than this is not sent again
  int timing_window = 2000;  ///< decisions whose verification time the percentiles are taken over, the newest
};

/// @brief Where a page is in the feed: what it has had. A new page starts at the default (everything is new).
struct ViewCursor {
  bool hello_sent = false;
  std::size_t keyframes = 0;      ///< keyframes sent (the feed's keyframes are append-only)
  std::int64_t pose_seq = 0;      ///< corrected poses changed after this were not sent
  std::int64_t decision_seq = 0;  ///< decisions after this were not sent
  std::int64_t cloud_seq = 0;     ///< clouds after this were not sent
  std::int64_t health_seq = 0;    ///< the health figures after this were not sent
};

/// @brief The state of the page, fed by the engine (or a stored map), read by every page's sender. Thread-safe.
class ViewFeed {
 public:
  explicit ViewFeed(ViewFeedConfig config = {});

  /// @brief What is shown ("live udpm://...", "replay drive.lcmlog", "map FILE"), in the page's title bar.
  void set_source(const std::string& source);
  /// @brief A keyframe: its odometry pose, its pose in the map when it was made, and its cloud (sensor frame; null:
  /// none), decimated to config.cloud_points and kept among the newest config.clouds.
  void add_keyframe(const KeyframeKey& key, std::int64_t utime, const Eigen::Isometry3d& T_odom_sensor, const Eigen::Isometry3d& T_map_sensor,
                    const std::vector<Eigen::Vector3f>* cloud_sensor);
  /// @brief A keyframe known by its pose in the map only (a stored map's keyframe whose cloud is not read).
  void add_map_keyframe(const KeyframeKey& key, std::int64_t utime, const Eigen::Isometry3d& T_odom_sensor, const Eigen::Isometry3d& T_map_sensor);
  /// @brief The cloud of a keyframe added before (a stored map's map cloud), in its sensor frame; `T_odom_sensor`
  /// gives its roll and pitch.
  void add_cloud(const KeyframeKey& key, const Eigen::Isometry3d& T_odom_sensor, const std::vector<Eigen::Vector3f>& cloud_sensor);
  /// @brief A loop decision (accepted or rejected at a stage), in the order decided.
  void add_decision(const LoopDecision& decision);
  /// @brief A correction: every keyframe's pose in the map. Poses that moved are sent again; keys not seen yet are
  /// added (keyframes restored from a map).
  void set_correction(std::int64_t revision, const std::vector<KeyframeKey>& keys, const std::vector<Eigen::Isometry3d>& T_map_sensor);
  /// @brief The health panel's figures (numbers and texts, shown in this order).
  void set_health(const std::vector<std::pair<std::string, double>>& numbers, const std::vector<std::pair<std::string, std::string>>& texts);

  /// @brief The next message for a page at `cursor`: a JSON object of what it has not had, of about `max_bytes` at
  /// most (one item more when not even one fits); "" when it has had everything. Advances `cursor`.
  std::string next_message(ViewCursor* cursor, std::size_t max_bytes) const;

  /// @brief Figures a test or the health panel reads.
  struct Counts {
    std::int64_t keyframes = 0, decisions = 0, accepted = 0, revision = 0;
    std::map<std::string, std::int64_t> stages;  ///< decisions by the stage they ended at ("accepted" for accepted)
  };
  Counts counts() const;

 private:
  struct Keyframe {
    KeyframeKey key;
    std::int64_t utime = 0;
    bool has_odometry = false;
    float odometry[4] = {0, 0, 0, 0};  ///< x, y, z, yaw [m, rad]
    float corrected[4] = {0, 0, 0, 0};
    std::int64_t pose_seq = 0;  ///< when `corrected` last changed (0: never: not sent as a pose)
  };
  struct Item {
    std::int64_t seq = 0;
    std::string json;
  };
  struct Budget;
  // next_message's parts (mutex held): what the page at `cursor` has not had, while `budget` lasts.
  void take_keyframes(ViewCursor* cursor, Budget& budget, std::vector<std::string>* out) const;
  void take_poses(ViewCursor* cursor, Budget& budget, std::vector<std::string>* out) const;
  void take_decisions(ViewCursor* cursor, Budget& budget, std::vector<std::string>* out) const;
  void take_clouds(ViewCursor* cursor, Budget& budget, std::vector<std::string>* out) const;
  std::size_t keyframe_id(const KeyframeKey& key, std::int64_t utime);     ///< adds it when new (mutex held)
  bool set_corrected(Keyframe& k, const Eigen::Isometry3d& T_map_sensor);  ///< true when it moved (mutex held)
  void push_cloud(const KeyframeKey& key, const Eigen::Isometry3d& T_sensor, const std::vector<Eigen::Vector3f>& cloud_sensor);

  ViewFeedConfig config_;
  mutable std::mutex mutex_;
  std::string source_;
  std::vector<Keyframe> keyframes_;
  std::unordered_map<KeyframeKey, std::size_t, KeyframeKeyHash> ids_;
  std::vector<std::size_t> correction_ids_;  ///< ids of the last correction's keys, by position (keys only grow)
  std::vector<KeyframeKey> correction_keys_;
  std::int64_t next_pose_seq_ = 1, revision_ = 0;
  std::vector<Item> accepted_;  ///< every accepted loop
  std::deque<Item> rejected_;   ///< the newest rejected decisions
  std::deque<Item> clouds_;     ///< the newest keyframe clouds
  std::int64_t next_seq_ = 1;   ///< decisions and clouds
  std::map<std::string, std::int64_t> stages_;
  std::int64_t decisions_ = 0;
  std::deque<float> verify_ms_;  ///< the newest decisions' verification time [ms]
  std::string health_;           ///< JSON object of the health figures
  std::int64_t health_seq_ = 0;
};

/// @brief `bytes` in base64 (RFC 4648, with padding).
std::string base64_encode(const std::uint8_t* bytes, std::size_t size);

}  // namespace loopd
