#include "loopd/io/kitti_files.hpp"

#include <cmath>
#include <fstream>
#include <optional>

#include "loopd/base/number_lines.hpp"

namespace loopd {

namespace {

/// Times beyond this [s] would overflow microsecond stamps (int64) downstream.
constexpr double kMaxSeconds = 1e11;

/// The key of a "key: values" line ("Tr", "P0", ...) whose colon is at `colon`, leading blanks removed.
std::string calib_key(const std::string& line, std::size_t colon) {
  std::string key = line.substr(0, colon);
  key.erase(0, key.find_first_not_of(" \t"));
  return key;
}

/// The 12 numbers after "Tr:" as T_cam_velo, or the reason they are not one (without the "<path>:<line>: " prefix).
KittiCalibration parse_calib_tr(const std::string& key, const std::string& values) {
  KittiCalibration c;
  const text::ParsedNumbers v = text::parse_numbers(values);
  if (!v.ok) {
    c.error = "not a number in " + key + ": '" + v.bad_token + "'";
    return c;
  }
  if (v.values.size() != 12) {
    c.error = key + " needs 12 numbers (3x4), got " + std::to_string(v.values.size());
    return c;
  }
  const text::ParsedIsometry T = text::checked_isometry_from_3x4(v.values.data());
  if (!T.ok) {
    c.error = key + ": " + T.error;
    return c;
  }
  c.T_cam_velo = T.T;
  c.ok = true;
  return c;
}

}  // namespace

KittiTimes read_kitti_times(const std::string& path) {
  KittiTimes t;
  std::ifstream in;
  if (auto reason = text::open_text_file(path, &in)) {
    t.error = *reason;
    return t;
  }
  const auto error = text::for_each_number_line(in, path, [&](const std::vector<double>& v) -> std::optional<std::string> {
    if (v.size() != 1) return "expected 1 number, got " + std::to_string(v.size());
    if (std::abs(v[0]) > kMaxSeconds) return "time " + std::to_string(v[0]) + " s is out of range (|t| <= 1e11 s)";
    if (!t.seconds.empty() && v[0] < t.seconds.back()) return "time goes backwards";
    t.seconds.push_back(v[0]);
    return std::nullopt;
  });
  if (error) {
    t.error = *error;
  } else if (t.seconds.empty()) {
    t.error = path + ": no times";
  } else {
    t.ok = true;
  }
  return t;
}

KittiCalibration read_kitti_calib_tr(const std::string& path) {
  std::ifstream in;
  if (auto reason = text::open_text_file(path, &in)) {
    KittiCalibration c;
    c.error = "cannot open calibration file: " + *reason;
    return c;
  }
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = calib_key(line, colon);
    if (key != "Tr" && key != "Tr_velo_to_cam") continue;
    KittiCalibration c = parse_calib_tr(key, line.substr(colon + 1));
    if (!c.ok) c.error = text::where(path, line_no) + c.error;
    return c;
  }
  KittiCalibration c;
  c.error = path + ": no 'Tr:' line (velodyne-to-camera transform)";
  return c;
}

std::vector<Eigen::Isometry3d> kitti_camera_to_lidar(const std::vector<Eigen::Isometry3d>& camera_poses, const Eigen::Isometry3d& T_cam_velo) {
  std::vector<Eigen::Isometry3d> out;
  out.reserve(camera_poses.size());
  const Eigen::Isometry3d Tr_inv = T_cam_velo.inverse();
  for (const auto& P : camera_poses) out.push_back(Tr_inv * P * T_cam_velo);
  return out;
}

TrajectoryFile read_kitti_lidar_poses(const std::string& poses_path, const std::string& calib_path) {
  const KittiCalibration calib = read_kitti_calib_tr(calib_path);
  if (!calib.ok) {
    TrajectoryFile f;
    f.error = calib.error;
    return f;
  }
  TrajectoryFile f = read_trajectory(poses_path, TrajectoryFormat::kKitti);
  if (f.ok) f.poses = kitti_camera_to_lidar(f.poses, calib.T_cam_velo);
  return f;
}

}  // namespace loopd
