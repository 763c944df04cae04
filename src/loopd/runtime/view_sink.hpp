#pragma once
/// @file The engine's results shown on the live page (--http): every keyframe, decision and correction that goes to
/// the output also goes into the ViewFeed the page's clients read. Placed just before the output, so the page shows
/// what was published (a decision the republish filter holds back is not shown twice).
#include "loopd/runtime/loopd_engine.hpp"
#include "loopd/store/map_store.hpp"
#include "loopd/web/view_feed.hpp"

namespace loopd {

/// @brief Forwards everything to `next` and copies what the page shows into `feed` (a mutex and an append each).
class ViewSink : public ForwardingSink {
 public:
  ViewSink(EngineSink& next, ViewFeed& feed) : ForwardingSink(next), feed_(feed) {}
  void on_keyframe(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_sensor, const MapCloudBlob& map_cloud) override;
  void on_decision(const LoopDecision& decision) override;
  void on_correction(const CorrectionOutput& correction) override;
  void on_final_correction(const CorrectionOutput& correction) override;

 private:
  ViewFeed& feed_;
};

/// @brief What of a stored map the page is given.
struct MapViewOptions {
  bool decisions = true;  ///< every stored decision (accepted and rejected)
  int clouds = 40;        ///< map clouds of the newest keyframes (0: none)
};

/// @brief A stored map into `feed`: every keyframe with its odometry pose and its pose in the map (the stored
/// correction's where it covers it), the stored decisions, and the newest keyframes' map clouds. For `loopd-map serve`
/// and for `loopd --map --http` before the run starts (the map's outline).
StoreStatus load_map_view(MapStore& store, ViewFeed& feed, const MapViewOptions& options);

}  // namespace loopd
