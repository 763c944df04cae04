#include "loopd/runtime/config_binder.hpp"
#include "loopd/runtime/loopd_engine.hpp"

namespace loopd {

void bind(Binder& b, EngineConfig& e) {
  b.field("threads", e.num_threads);
  b.field("queue_capacity", e.queue_capacity);
  b.field("max_points_per_scan", e.max_points_per_scan);
  b.field("input.clock_jump", e.clock_jump);
  b.field("input.max_odometry_speed", e.max_odometry_speed);
  b.field("association.tolerance", e.association.tolerance);
  b.field("association.hold_time", e.association.hold_time);
  b.field("association.max_pending_scans", e.association.max_pending_scans);
  b.field("association.max_poses", e.association.max_poses);
  b.field("deskew.enabled", e.deskew.enabled);
  b.field("deskew.from_scans", e.deskew_from_scans);
  b.field("deskew.compensated_upstream", e.compensated_upstream);
  b.field("deskew.sweep_motion.voxel_size", e.sweep_motion.voxel_size);
  b.field("deskew.sweep_motion.max_input_points", e.sweep_motion.max_input_points);
  b.field("deskew.sweep_motion.rounds", e.sweep_motion.rounds);
  b.field("deskew.sweep_motion.max_source_points", e.sweep_motion.gicp.max_source_points);
  b.field("deskew.sweep_motion.max_degeneracy", e.sweep_motion.max_degeneracy);
  b.field("deskew.sweep_motion.shape.segments", e.sweep_motion.shape.segments);
  b.field("deskew.sweep_motion.shape.yaw_only", e.sweep_motion.shape.yaw_only);
  b.field("deskew.sweep_motion.shape.min_rate_change_deg", e.sweep_motion.shape.min_rate_change_deg);
  b.field("imu.enabled", e.imu.enabled);
  b.field("imu.rpy_deg", e.imu.rpy_deg);
  b.field("imu.max_gap", e.imu.max_gap);
  b.field("retirement.enabled", e.retirement.enabled);
  b.field("retirement.radius_per_spacing", e.retirement.radius_per_spacing);
  b.field("retirement.max_rotation_deg", e.retirement.max_rotation_deg);
  b.field("retirement.keep", e.retirement.keep);
  b.field("retirement.same_pass_radii", e.retirement.same_pass_radii);
  b.field("submap.enabled", e.submap.enabled);
  b.field("submap.max_coverage_deg", e.submap.max_coverage_deg);
  int submap_min_points = static_cast<int>(e.submap.min_points);
  b.field("submap.min_points", submap_min_points);
  e.submap.min_points = static_cast<std::size_t>(std::max(0, submap_min_points));
  b.field("submap.window", e.submap.window);
  b.field("submap.max_travel", e.submap.max_travel);
  b.field("submap.max_scans", e.submap.max_scans);
  b.field("submap.confirm", e.submap.confirm);
  b.field("deskew.max_sweep", e.deskew.max_sweep);
  b.field("deskew.max_extrapolation", e.deskew.max_extrapolation);
  b.field("deskew.max_pose_gap", e.deskew.max_pose_gap);
  b.field("deskew.time_bins", e.deskew.time_bins);
  b.field("map.clouds", e.map_cloud.enabled);
  b.field("map.cloud_voxel", e.map_cloud.voxel);
  b.field("map.cloud_min_range", e.map_cloud.min_range);
  b.field("map.cloud_max_range", e.map_cloud.max_range);
  b.field("map.cloud_quantum", e.map_cloud.quantum);
  bind(b, e.detector, e.sessions);
}

}  // namespace loopd
