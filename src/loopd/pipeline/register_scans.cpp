#include "loopd/pipeline/register_scans.hpp"

namespace loopd {

PrepareConfig registration_prepare_config() {
  PrepareConfig c;
  c.voxel_size = 0.5;
  c.min_range = 1.0;
  c.max_range = 80.0;
  c.max_points = 0;
  c.normal_k_neighbors = 0;
  return c;
}

std::optional<std::string> ScanRegistrationConfig::validate() const {
  if (auto e = prepare.validate()) return "prepare: " + *e;
  if (auto e = four_pcs.validate()) return "four_pcs: " + *e;
  return std::nullopt;
}

FourPcsResult register_scans(const PointCloud& source, const PointCloud& target, const LidarModel* model, const ScanRegistrationConfig& config,
                             double* ms_prepare) {
  if (auto e = config.validate()) {
    FourPcsResult r;
    r.reason = "invalid ScanRegistrationConfig: " + *e;
    return r;
  }
  const PreparedScan s = prepare_scan(source, model, config.prepare);
  const PreparedScan t = prepare_scan(target, model, config.prepare);
  if (ms_prepare != nullptr) *ms_prepare = s.ms_total + t.ms_total;
  return align_four_pcs(s.points, s.segmentation, t.points, t.segmentation, config.four_pcs);
}

}  // namespace loopd
