#include "loopd/verify/verify.hpp"

#include "loopd/base/information.hpp"

#include <sstream>

#include "loopd/base/stopwatch.hpp"
#include "loopd/verify/cluster_consistency.hpp"

namespace loopd {
namespace {

ClusterConsistencyConfig consistency_config(const VerifyConfig& c) {
  ClusterConsistencyConfig cc;
  cc.match_distance = c.hungarian_match_distance;
  cc.max_cluster_extent = c.consistency_max_cluster_extent;
  cc.min_cluster_points = c.consistency_min_cluster_points;
  cc.max_range = c.consistency_max_range;
  cc.min_clusters = c.consistency_min_clusters;
  return cc;
}

bool check_input(const PreparedScan& query, const PreparedScan& match, const VerifyConfig& config, VerifyResult* r) {
  r->stage = VerifyStage::kInput;
  if (auto err = config.validate()) {
    r->reason = "invalid config: " + *err;
    return false;
  }
  for (const auto* s : {&query, &match}) {
    const char* which = s == &query ? "query" : "match";
    if (!s->error.empty()) {
      r->reason = std::string(which) + " scan unusable: " + s->error;
      return false;
    }
    if (static_cast<int>(s->points.size()) < config.min_points) {
      r->reason = std::string(which) + " scan has " + std::to_string(s->points.size()) + " points, need " + std::to_string(config.min_points);
      return false;
    }
  }
  return true;
}

/// GICP, degeneracy and centroid stages from an initial estimate (Vlaminck 2019, Sec. 4.3).
void refine_and_check(const PreparedScan& query, const PreparedScan& match, const Eigen::Isometry3d& init, const VerifyConfig& config,
                      VerifyResult* r) {
  Stopwatch sw;
  // Source = query, target = match: T_target_source = T_match_query.
  // Cached per-keyframe normals (prepare_scan); empty ones are estimated inside align_gicp.
  const GicpResult g = align_gicp(query.points, query.unpacked_normals(), match.points, match.unpacked_normals(), init, config.gicp);
  r->ms_gicp = sw.ms();
  r->T_match_query = g.T_target_source;
  r->icp_residual = g.residual;
  r->icp_fitness = g.fitness;
  r->icp_iterations = g.iterations;
  r->icp_converged = g.converged;
  r->information = information_from_rotation_first(g.H);
  r->degeneracy = g.degeneracy;
  r->weakest_direction = g.weakest_direction;
  std::ostringstream why;
  r->stage = VerifyStage::kGicp;
  if (!g.converged) {
    why << "GICP did not converge: " << g.reason;
  } else if (g.fitness < config.min_icp_fitness) {
    why << "GICP fitness " << g.fitness << " < " << config.min_icp_fitness;
  } else if (g.residual > config.max_icp_residual) {
    why << "GICP residual " << g.residual << " m > " << config.max_icp_residual << " m";
  }
  if (!why.str().empty()) {
    r->reason = why.str();
    return;
  }

  // Corridor-like ambiguity: the translation along one axis is barely constrained (Hessian degeneracy).
  r->stage = VerifyStage::kDegeneracy;
  r->degenerate = !(g.degeneracy <= config.max_degeneracy_ratio);
  std::string flag;
  if (r->degenerate) {
    why << "degenerate alignment: translational information condition number " << g.degeneracy << " > " << config.max_degeneracy_ratio
        << " (weakest direction " << g.weakest_direction.transpose() << ")";
    if (config.reject_degenerate) {
      r->reason = why.str();
      return;
    }
    flag = why.str();
  }

  // Vlaminck 2019 Sec. 4.3: are the objects still at the same place? Hungarian matching of cluster centroids.
  sw.reset();
  r->stage = VerifyStage::kHungarian;
  const ClusterConsistencyResult c = cluster_consistency(query.segmentation, match.segmentation, r->T_match_query, consistency_config(config));
  r->ms_hungarian = sw.ms();
  r->hungarian_consistency = c.consistency;
  r->clusters_query = c.num_query;
  r->clusters_match = c.num_match;
  r->clusters_matched = c.num_matched;
  if (c.consistency < 0.0) {
    if (config.reject_unjudgeable_consistency) {
      r->reason = "centroid check impossible: " + c.reason;
      return;
    }
    flag += (flag.empty() ? "" : "; ") + std::string("centroid check skipped: ") + c.reason;
  } else if (c.consistency < config.min_hungarian_consistency) {
    std::ostringstream os;
    os << "cluster consistency " << c.consistency << " < " << config.min_hungarian_consistency << " (" << c.num_matched << " of min(" << c.num_query
       << ", " << c.num_match << ") within " << config.hungarian_match_distance << " m)";
    r->reason = os.str();
    return;
  }
  r->stage = VerifyStage::kAccepted;
  r->accepted = true;
  r->reason = flag;
}

}  // namespace

std::string to_string(VerifyStage stage) {
  switch (stage) {
    case VerifyStage::kInput:
      return "input";
    case VerifyStage::kFourPcs:
      return "fourpcs";
    case VerifyStage::kGicp:
      return "gicp";
    case VerifyStage::kDegeneracy:
      return "degeneracy";
    case VerifyStage::kHungarian:
      return "hungarian";
    case VerifyStage::kAccepted:
      return "accepted";
  }
  return "unknown";
}

std::optional<std::string> VerifyConfig::validate() const {
  if (auto err = four_pcs.validate()) return "four_pcs: " + *err;
  if (auto err = gicp.validate()) return "gicp: " + *err;
  if (min_points < 10) return "VerifyConfig.min_points must be >= 10";
  if (!(min_lcp_fraction >= 0.0 && min_lcp_fraction <= 1.0)) return "VerifyConfig.min_lcp_fraction must be in [0, 1]";
  if (!(max_icp_residual > 0.0)) return "VerifyConfig.max_icp_residual must be positive";
  if (!(min_icp_fitness >= 0.0 && min_icp_fitness <= 1.0)) return "VerifyConfig.min_icp_fitness must be in [0, 1]";
  if (!(max_degeneracy_ratio >= 1.0)) return "VerifyConfig.max_degeneracy_ratio must be >= 1";
  if (!(min_hungarian_consistency >= 0.0 && min_hungarian_consistency <= 1.0)) return "VerifyConfig.min_hungarian_consistency must be in [0, 1]";
  if (auto err = consistency_config(*this).validate()) return *err;
  return std::nullopt;
}

VerifyResult verify(const PreparedScan& query, const PreparedScan& match, const VerifyConfig& config) {
  Stopwatch total;
  VerifyResult r;
  if (check_input(query, match, config, &r)) {
    // Vlaminck 2019 Sec. 4.2: global alignment without an initial guess (revisits from any direction).
    Stopwatch sw;
    const FourPcsResult f = align_four_pcs(query.points, query.segmentation, match.points, match.segmentation, config.four_pcs);
    r.ms_fourpcs = sw.ms();
    r.stage = VerifyStage::kFourPcs;
    r.lcp_fraction = f.success ? f.lcp_fraction : (f.lcp_fraction > 0 ? f.lcp_fraction : -1.0);
    r.T_match_query = f.T_target_source;
    r.T_match_query_fourpcs = f.T_target_source;
    if (!f.success) {
      r.reason = "4PCS found no alignment: " + f.reason;
    } else if (f.lcp_fraction < config.min_lcp_fraction) {
      std::ostringstream os;
      os << "4PCS LCP fraction " << f.lcp_fraction << " < " << config.min_lcp_fraction;
      r.reason = os.str();
    } else {
      refine_and_check(query, match, f.T_target_source, config, &r);
    }
  }
  r.ms_total = total.ms();
  return r;
}

VerifyResult verify_from_guess(const PreparedScan& query, const PreparedScan& match, const Eigen::Isometry3d& init_T_match_query,
                               const VerifyConfig& config) {
  Stopwatch total;
  VerifyResult r;
  r.T_match_query = init_T_match_query;
  r.T_match_query_fourpcs = init_T_match_query;
  if (check_input(query, match, config, &r)) {
    if (!init_T_match_query.matrix().allFinite()) {
      r.reason = "initial guess is not finite";
    } else {
      refine_and_check(query, match, init_T_match_query, config, &r);
    }
  }
  r.ms_total = total.ms();
  return r;
}

}  // namespace loopd
