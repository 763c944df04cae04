#include "loopd/registration/scan_registration.hpp"

#include "loopd/core/cloud_ops.hpp"
#include "loopd/core/stopwatch.hpp"

namespace loopd {

std::optional<std::string> ScanRegistrationConfig::validate() const {
  if (voxel_size <= 0) return "voxel_size must be > 0";
  if (min_range < 0 || max_range <= min_range) return "need 0 <= min_range < max_range";
  if (auto e = segmentation.validate()) return "segmentation: " + *e;
  if (auto e = four_pcs.validate()) return "four_pcs: " + *e;
  return std::nullopt;
}

RegistrationInput prepare_registration_input(const PointCloud& scan, const LidarModel* model, const ScanRegistrationConfig& config) {
  Stopwatch sw;
  RegistrationInput in;
  SegmentationConfig seg = config.segmentation;
  seg.min_range = config.min_range;
  seg.max_range = config.max_range;
  in.segmentation = segment(scan, model, seg);  // NaN and range are filtered inside (the range image needs the raw order)
  in.points = voxel_downsample(crop_range(remove_non_finite(scan), config.min_range, config.max_range), config.voxel_size).points;
  in.ms = sw.ms();
  return in;
}

FourPcsResult register_scans(const PointCloud& source, const PointCloud& target, const LidarModel* model, const ScanRegistrationConfig& config,
                             double* ms_prepare) {
  if (auto e = config.validate()) {
    FourPcsResult r;
    r.reason = "invalid ScanRegistrationConfig: " + *e;
    return r;
  }
  const RegistrationInput s = prepare_registration_input(source, model, config);
  const RegistrationInput t = prepare_registration_input(target, model, config);
  if (ms_prepare != nullptr) *ms_prepare = s.ms + t.ms;
  return align_four_pcs(s.points, s.segmentation, t.points, t.segmentation, config.four_pcs);
}

}  // namespace loopd
