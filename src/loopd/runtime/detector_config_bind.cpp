#include "loopd/runtime/config_binder.hpp"
#include "loopd/runtime/loopd_engine.hpp"

namespace loopd {
namespace {

/// The stage configs of the detector (descriptor, preparation, verification, correction).
void bind_stage_configs(Binder& b, LoopDetectorConfig& d) {
  M2dpConfig& m = d.m2dp;
  b.field("descriptor.l", m.num_rings_l);
  b.field("descriptor.t", m.num_sectors_t);
  b.field("descriptor.p", m.num_azimuths_p);
  b.field("descriptor.q", m.num_elevations_q);
  b.choice("descriptor.frame", m.frame, {{"gravity", M2dpFrame::kGravityAligned}, {"pca", M2dpFrame::kPca}});
  b.choice("descriptor.backend", m.backend, {{"auto", Backend::kAuto}, {"opencl", Backend::kOpenCl}, {"cpu", Backend::kCpu}});
  b.field("descriptor.opencl_device", m.opencl_device);
  b.field("descriptor.max_points", m.max_points);

  PrepareConfig& p = d.prepare;
  b.field("keyframe_cloud.voxel_size", p.voxel_size);
  b.field("keyframe_cloud.min_range", p.min_range);
  b.field("keyframe_cloud.max_range", p.max_range);
  int max_points = static_cast<int>(p.max_points);
  b.field("keyframe_cloud.max_points", max_points);
  p.max_points = static_cast<std::size_t>(std::max(0, max_points));
  SegmentationConfig& sg = p.segmentation;
  b.field("segmentation.max_neighbor_distance", sg.max_neighbor_distance);
  b.field("segmentation.distance_range_scale", sg.distance_range_scale);
  b.field("segmentation.max_normal_angle_deg", sg.max_normal_angle_deg);
  b.field("segmentation.min_cluster_points", sg.min_cluster_points);
  b.field("segmentation.plane_rms_tolerance", sg.plane_rms_tolerance);
  b.field("segmentation.max_clusters", sg.max_clusters);

  VerifyConfig& v = d.verify;
  b.field("fourpcs.delta", v.four_pcs.delta);
  b.field("fourpcs.max_bases", v.four_pcs.max_bases);
  b.field("fourpcs.min_base_width", v.four_pcs.min_base_width);
  b.field("fourpcs.max_angle_deviation_deg", v.four_pcs.max_angle_deviation_deg);
  b.field("fourpcs.max_tilt_deg", v.four_pcs.max_tilt_deg);
  b.field("fourpcs.lcp_sample_points", v.four_pcs.lcp_sample_points);
  b.field("fourpcs.num_threads", v.four_pcs.num_threads);
  b.field("gicp.k_neighbors", v.gicp.k_neighbors);
  b.field("gicp.epsilon", v.gicp.epsilon);
  b.field("gicp.max_iterations", v.gicp.max_iterations);
  b.field("gicp.num_threads", v.gicp.num_threads);
  b.field("verify.min_points", v.min_points);
  b.field("verify.min_lcp_fraction", v.min_lcp_fraction);
  b.field("verify.max_icp_residual", v.max_icp_residual);
  b.field("verify.min_icp_fitness", v.min_icp_fitness);
  b.field("verify.max_degeneracy_ratio", v.max_degeneracy_ratio);
  b.field("verify.reject_degenerate", v.reject_degenerate);
  b.field("verify.hungarian_match_distance", v.hungarian_match_distance);
  b.field("verify.min_hungarian_consistency", v.min_hungarian_consistency);
  b.field("verify.reject_unjudgeable_consistency", v.reject_unjudgeable_consistency);

  LoopCorrectorConfig& c = d.correction;
  b.choice(
      "correction.method", c.method,
      {{"heuristic+graph", CorrectionMethod::kHeuristicThenGraph}, {"heuristic", CorrectionMethod::kHeuristic}, {"graph", CorrectionMethod::kGraph}});
  b.choice("correction.graph.loop_loss", c.graph.loop_loss,
           {{"cauchy", RobustLoss::kCauchy}, {"huber", RobustLoss::kHuber}, {"none", RobustLoss::kNone}});
  b.field("correction.graph_interval", c.graph_interval);
  b.field("correction.graph_interval_fraction", c.graph_interval_fraction);
  b.field("correction.graph_apply_after", c.graph_apply_after);
  b.field("correction.graph_apply_fraction", c.graph_apply_fraction);
  b.field("correction.graph_solve_nice", c.graph_solve_nice);
  b.field("correction.graph_now_translation", c.graph_now_translation);
  b.field("correction.graph_now_rotation_deg", c.graph_now_rotation_deg);
  b.field("correction.graph.loop_loss_scale", c.graph.loop_loss_scale);
  b.field("correction.graph.odometry_translation_sigma", c.graph.odometry_translation_sigma);
  b.field("correction.graph.odometry_rotation_sigma", c.graph.odometry_rotation_sigma);
  b.field("correction.graph.max_iterations", c.graph.max_iterations);
  b.field("correction.graph.max_nodes", c.graph.max_nodes);
  b.field("correction.graph.max_loop_information", c.graph.max_loop_information);
  b.field("correction.graph.min_loop_information", c.graph.min_loop_information);
  b.field("correction.graph.reduce_chains", c.graph.reduce_chains);
  b.field("correction.steps.enabled", d.steps.enabled);
  b.field("correction.steps.max_translation_change", d.steps.max_translation_change);
  b.field("correction.steps.max_rotation_change_deg", d.steps.max_rotation_change_deg);
  b.field("correction.steps.min_fitness", d.steps.min_fitness);
  b.field("correction.steps.max_degeneracy", d.steps.max_degeneracy);
  b.field("correction.steps.translation_sigma", d.steps.translation_sigma);
  b.field("correction.steps.rotation_sigma", d.steps.rotation_sigma);
  b.field("correction.steps.tilt_from_odometry", d.steps.tilt_from_odometry);
  b.field("correction.steps.max_unskewed_motion", d.steps.max_unskewed_motion);
  b.field("correction.steps.max_unskewed_rotation_deg", d.steps.max_unskewed_rotation_deg);
  b.field("correction.graph.use_plane_constraints", c.graph.use_plane_constraints);
  b.field("correction.graph.plane_cell_size", d.plane_cell_size);
}

/// Global retrieval (the detector's second descriptor) and when sessions open.
void bind_retrieval_and_sessions(Binder& b, LoopDetectorConfig& d, SessionPolicy& sessions) {
  GlobalRetrievalConfig& r = d.retrieval;
  b.field("retrieval.enabled", r.enabled);
  b.field("retrieval.k", r.retrieval.k);
  b.field("retrieval.ring_candidates", r.retrieval.ring_candidates);
  double max_place_distance = r.retrieval.max_place_distance;
  b.field("retrieval.max_place_distance", max_place_distance);
  r.retrieval.max_place_distance = static_cast<float>(max_place_distance);
  b.field("retrieval.max_verified", r.max_verified);
  b.field("retrieval.lateral_shift", r.lateral_shift);
  b.field("retrieval.min_travel_gap", r.min_travel_gap);
  b.field("retrieval.max_drift_fraction", r.max_drift_fraction);
  b.field("retrieval.confirm_window", r.confirm_window);
  b.field("retrieval.confirm_translation", r.confirm_translation);
  b.field("retrieval.confirm_rotation_deg", r.confirm_rotation_deg);
  b.field("retrieval.descriptor.rings", r.descriptor.num_rings);
  b.field("retrieval.descriptor.sectors", r.descriptor.num_sectors);
  double max_range = r.descriptor.max_range, height_offset = r.descriptor.height_offset;
  b.field("retrieval.descriptor.max_range", max_range);
  b.field("retrieval.descriptor.height_offset", height_offset);
  r.descriptor.max_range = static_cast<float>(max_range);
  r.descriptor.height_offset = static_cast<float>(height_offset);
  b.choice("sessions.on_odometry_reset", sessions.new_session_on_reset, {{"new_session", true}, {"stitch", false}});
  b.field("sessions.resume_max_gap", sessions.resume_max_gap);
}

}  // namespace

void bind(Binder& b, LoopDetectorConfig& d, SessionPolicy& sessions) {
  b.field("sensor", d.sensor);
  b.field("sensor_elevations_deg", d.sensor_elevations_deg);
  b.field("sensor_columns", d.sensor_columns);
  b.field("keyframe.min_distance", d.keyframe.min_distance);
  b.field("keyframe.min_rotation_deg", d.keyframe.min_rotation_deg);
  b.field("keyframe.max_interval", d.keyframe.max_interval);
  b.field("keyframe.spacing_per_scale", d.keyframe.spacing_per_scale);
  b.field("keyframe.min_spacing", d.keyframe.min_spacing);
  b.field("gate.travel_fraction", d.gate.travel_fraction);
  b.field("gate.min_radius", d.gate.min_radius);
  b.field("gate.max_radius", d.gate.max_radius);
  b.field("gate.min_index_gap", d.gate.min_index_gap);
  b.field("gate.min_travel_gap", d.gate.min_travel_gap);
  b.field("gate.travel_gap_per_scale", d.gate.travel_gap_per_scale);
  b.field("gate.min_travel_gap_floor", d.gate.min_travel_gap_floor);
  b.field("gate.travel_gap_per_radius", d.gate.travel_gap_per_radius);
  b.field("descriptor.max_distance", d.max_descriptor_distance);
  b.field("verify.small_scene_scale", d.small_scene_scale);
  b.field("verify.max_prior_rotation_deg", d.max_prior_rotation_deg);
  b.field("descriptor.max_candidates", d.max_candidates_per_keyframe);
  b.field("verify.guided_window", d.guided_window);
  bind_stage_configs(b, d);
  bind_retrieval_and_sessions(b, d, sessions);
}

}  // namespace loopd
