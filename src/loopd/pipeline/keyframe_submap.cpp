#include "loopd/pipeline/keyframe_submap.hpp"

#include "loopd/base/fast_atan2.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace loopd {

std::optional<std::string> KeyframeSubmapConfig::validate() const {
  if (!(max_coverage_deg >= 0.0 && max_coverage_deg <= 360.0)) return std::string("submap.max_coverage_deg must be in [0, 360]");
  if (!(window >= 0.0 && window <= 10.0)) return std::string("submap.window must be in [0, 10] s");
  if (!(max_travel >= 0.0 && std::isfinite(max_travel))) return std::string("submap.max_travel must be >= 0 [m]");
  if (max_scans < 0 || max_scans > 100) return std::string("submap.max_scans must be in [0, 100]");
  if (confirm < 1) return std::string("submap.confirm must be >= 1");
  return std::nullopt;
}

bool needs_submap(const PointCloud& scan, const KeyframeSubmapConfig& config) {
  if (!config.enabled) return false;
  // Every scan is asked (the mode follows the sensor): every 7th point (odd: no aliasing with power-of-two ring
  // counts), the returns estimated from them.
  constexpr std::size_t kStride = 7;
  std::array<int, 72> sectors{};  // 5 deg each
  std::size_t sampled = 0;
  for (std::size_t i = 0; i < scan.points.size(); i += kStride) {
    const Eigen::Vector3f& p = scan.points[i];
    if (!p.allFinite() || p.squaredNorm() < 0.01f) continue;
    ++sampled;
    const float a = fast_atan2(p.y(), p.x()) * static_cast<float>(72.0 / (2.0 * M_PI)) + 36.0f;
    ++sectors[static_cast<std::size_t>(std::clamp(static_cast<int>(a), 0, 71))];
  }
  const std::size_t finite = sampled * kStride;  // estimated returns
  if (finite < config.min_points) return true;
  // A sector counts when it holds at least 1 % of an even share: stray returns do not widen a cone.
  const double floor = 0.01 * static_cast<double>(sampled) / 72.0;
  const int covered = static_cast<int>(std::count_if(sectors.begin(), sectors.end(), [&](int n) { return n > floor; }));
  return covered * 5.0 < config.max_coverage_deg;
}

bool ScanWindow::update_mode(bool scan_needs_submap) {
  disagreeing_ = scan_needs_submap == submaps_ ? 0 : disagreeing_ + 1;
  if (disagreeing_ >= config_.confirm) {
    submaps_ = scan_needs_submap;
    disagreeing_ = 0;
    if (!submaps_) scans_.clear();
  }
  return submaps_;
}

void ScanWindow::push(std::shared_ptr<const WindowScan> scan) {
  const auto keep_us = static_cast<std::int64_t>(config_.window * 1e6);
  while (!scans_.empty() && scan->utime - scans_.front()->utime > keep_us) scans_.pop_front();
  scans_.push_back(std::move(scan));
  while (static_cast<int>(scans_.size()) > std::max(1, config_.max_scans + 1)) scans_.pop_front();
}

std::vector<std::shared_ptr<const WindowScan>> ScanWindow::recent(std::int64_t utime, const Eigen::Isometry3d& T_odom_keyframe) const {
  std::vector<std::shared_ptr<const WindowScan>> out;
  const auto keep_us = static_cast<std::int64_t>(config_.window * 1e6);
  for (auto it = scans_.rbegin(); it != scans_.rend() && static_cast<int>(out.size()) < config_.max_scans; ++it) {
    const WindowScan& s = **it;
    if (s.utime >= utime) continue;  // the keyframe's own scan
    if (utime - s.utime > keep_us) break;
    if ((s.T_odom_sensor.translation() - T_odom_keyframe.translation()).norm() > config_.max_travel) break;
    out.push_back(*it);
  }
  std::reverse(out.begin(), out.end());
  return out;
}

int merge_submap(const std::vector<std::shared_ptr<const WindowScan>>& earlier, const Eigen::Isometry3d& T_odom_keyframe,
                 const DeskewConfig& deskew_config, PointCloud* cloud) {
  cloud->ring.clear();
  cloud->num_rings = 0;
  cloud->time.clear();
  const bool intensity = cloud->has_intensity();
  int merged = 0;
  for (const auto& scan : earlier) {
    PointCloud c = scan->cloud;
    if (deskew_config.enabled && c.has_time()) deskew(deskew_config, scan->sweep_poses, scan->utime, &c);
    const Eigen::Isometry3f T_keyframe_scan = (T_odom_keyframe.inverse() * scan->T_odom_sensor).cast<float>();
    for (std::size_t i = 0; i < c.size(); ++i) {
      if (!c.points[i].allFinite()) continue;
      cloud->points.push_back(T_keyframe_scan * c.points[i]);
      if (intensity) cloud->intensity.push_back(c.has_intensity() ? c.intensity[i] : 0.f);
    }
    ++merged;
  }
  return merged;
}

}  // namespace loopd
