#include "loopd/core/trajectory_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace loopd {

namespace text {

bool parse_numbers(const std::string& line, std::vector<double>* out, std::string* bad_token, std::string* reason) {
  out->clear();
  std::istringstream ss(line);
  std::string tok;
  while (ss >> tok) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || end != tok.c_str() + tok.size()) {  // also a token with a NUL byte inside
      if (bad_token) *bad_token = tok;
      if (reason) *reason = "'" + tok + "' is not a number";
      return false;
    }
    if (!std::isfinite(v)) {
      if (bad_token) *bad_token = tok;
      if (reason) *reason = "non-finite value '" + tok + "'";
      return false;
    }
    out->push_back(v);
  }
  return true;
}

bool skip_line(const std::string& line) {
  const auto p = line.find_first_not_of(" \t\r");
  return p == std::string::npos || line[p] == '#';
}

std::string where(const std::string& source, int line) { return source + ":" + std::to_string(line) + ": "; }

std::string open_text_file(const std::string& path, std::ifstream* in) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return path + ": is a directory, not a file";
  in->open(path);
  if (!*in) return path + ": cannot open";
  return {};
}

std::string for_each_number_line(std::istream& in, const std::string& source,
                                 const std::function<std::string(const std::vector<double>&)>& on_numbers) {
  std::string line, reason;
  std::vector<double> v;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (skip_line(line)) continue;
    if (!parse_numbers(line, &v, nullptr, &reason)) return where(source, line_no) + reason;
    reason = on_numbers(v);
    if (!reason.empty()) return where(source, line_no) + reason;
  }
  return {};
}

Eigen::Isometry3d isometry_from_3x4(const double* v) {
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = v[r * 4 + c];
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(v[3], v[7], v[11]);
  return T;
}

bool checked_isometry_from_3x4(const double* v, Eigen::Isometry3d* T, std::string* reason) {
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = v[r * 4 + c];
  const double orth = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  // Written so that NaN (from huge values that overflow) fails too.
  if (!(orth <= 1e-2) || !(R.determinant() > 0.0)) {
    *reason = "rotation part is not a rotation matrix (|R^T R - I| = " + std::to_string(orth) + ")";
    return false;
  }
  *T = isometry_from_3x4(v);
  return true;
}

}  // namespace text

namespace {

/// Times beyond this [s] would overflow microsecond stamps (int64) downstream.
constexpr double kMaxSeconds = 1e11;

bool is_blank(const std::string& s) { return s.find_first_not_of(" \t\r") == std::string::npos; }

/// Reads the numbers of every line of a KITTI file (poses, times): an empty line is allowed only at the end (in the
/// middle it would shift every later entry). Calls on_numbers(line_no, numbers) -> error reason ("" = fine).
template <typename OnNumbers>
bool read_kitti_lines(const std::string& path, const std::string& what, const std::string& expected,
                      std::string* error, OnNumbers on_numbers) {
  std::ifstream in;
  if (std::string reason = text::open_text_file(path, &in); !reason.empty()) {
    if (error) *error = "cannot open " + what + " file: " + reason;
    return false;
  }
  std::string line, bad;
  std::vector<double> v;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::string reason;
    if (is_blank(line)) {
      if (in.peek() == EOF) break;
      reason = "empty line (expected " + expected + ")";
    } else if (!text::parse_numbers(line, &v, &bad, nullptr)) {
      reason = "not a number: '" + bad + "'";
    } else {
      reason = on_numbers(v);
    }
    if (!reason.empty()) {
      if (error) *error = text::where(path, line_no) + reason;
      return false;
    }
  }
  return true;
}

}  // namespace

std::optional<TrajectoryFormat> trajectory_format_from_string(const std::string& name) {
  if (name == "kitti") return TrajectoryFormat::kKitti;
  if (name == "tum") return TrajectoryFormat::kTum;
  return std::nullopt;
}

TrajectoryFile parse_trajectory(std::istream& in, TrajectoryFormat format, const std::string& source) {
  TrajectoryFile f;
  const std::size_t want = format == TrajectoryFormat::kKitti ? 12 : 8;
  f.error = text::for_each_number_line(in, source, [&](const std::vector<double>& v) -> std::string {
    if (v.size() != want)
      return "expected " + std::to_string(want) + " numbers (" +
             (format == TrajectoryFormat::kKitti ? "3x4 row-major pose" : "t x y z qx qy qz qw") + "), got " + std::to_string(v.size());
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    if (format == TrajectoryFormat::kKitti) {
      std::string reason;
      if (!text::checked_isometry_from_3x4(v.data(), &T, &reason)) return reason;
      f.stamps.push_back(static_cast<double>(f.poses.size()));
    } else {
      const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
      if (std::abs(q.norm() - 1.0) > 1e-2) return "quaternion is not unit length (|q| = " + std::to_string(q.norm()) + ")";
      T.linear() = q.normalized().toRotationMatrix();
      T.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
      f.stamps.push_back(v[0]);
    }
    f.poses.push_back(T);
    return {};
  });
  if (!f.error.empty()) return f;
  if (f.poses.empty()) f.error = source + ": no poses";
  return f;
}

TrajectoryFile read_trajectory(const std::string& path, TrajectoryFormat format) {
  std::ifstream in;
  if (std::string reason = text::open_text_file(path, &in); !reason.empty()) {
    TrajectoryFile f;
    f.error = reason;
    return f;
  }
  return parse_trajectory(in, format, path);
}

std::optional<std::string> write_trajectory(const std::string& path, const std::vector<Eigen::Isometry3d>& poses,
                                            const std::vector<double>& stamps, TrajectoryFormat format) {
  std::ofstream out(path);
  if (!out) return path + ": cannot open for writing";
  out << std::setprecision(9);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Isometry3d& T = poses[i];
    if (format == TrajectoryFormat::kKitti) {
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) out << (r || c ? " " : "") << T.matrix()(r, c);
    } else {
      const Eigen::Quaterniond q(T.linear());
      const double t = i < stamps.size() ? stamps[i] : static_cast<double>(i);
      out << std::setprecision(17) << t << std::setprecision(9) << " " << T.translation().x() << " " << T.translation().y() << " "
          << T.translation().z() << " " << q.x() << " " << q.y() << " " << q.z() << " " << q.w();
    }
    out << "\n";
  }
  if (!out) return path + ": write failed";
  return std::nullopt;
}

bool write_tum_trajectory(const std::string& path, const std::vector<std::int64_t>& utimes,
                          const std::vector<Eigen::Isometry3d>& poses, std::string* error) {
  const std::size_t n = std::min(utimes.size(), poses.size());
  std::vector<double> seconds(n);
  for (std::size_t i = 0; i < n; ++i) seconds[i] = static_cast<double>(utimes[i]) * 1e-6;
  const auto e = write_trajectory(path, std::vector<Eigen::Isometry3d>(poses.begin(), poses.begin() + static_cast<std::ptrdiff_t>(n)),
                                  seconds, TrajectoryFormat::kTum);
  if (e && error) *error = *e;
  return !e;
}

bool write_kitti_trajectory(const std::string& path, const std::vector<Eigen::Isometry3d>& poses, std::string* error) {
  const auto e = write_trajectory(path, poses, {}, TrajectoryFormat::kKitti);
  if (e && error) *error = *e;
  return !e;
}

bool read_kitti_poses(const std::string& path, std::vector<Eigen::Isometry3d>* poses, std::string* error) {
  poses->clear();
  const bool ok = read_kitti_lines(path, "poses", "12 numbers", error, [&](const std::vector<double>& v) -> std::string {
    if (v.size() != 12) return "expected 12 numbers (3x4 pose), got " + std::to_string(v.size());
    Eigen::Isometry3d T;
    std::string reason;
    if (!text::checked_isometry_from_3x4(v.data(), &T, &reason)) return reason;
    poses->push_back(T);
    return {};
  });
  if (!ok) return false;
  if (poses->empty()) {
    if (error) *error = "poses file " + path + " holds no poses";
    return false;
  }
  return true;
}

bool read_kitti_times(const std::string& path, std::vector<double>* seconds, std::string* error) {
  seconds->clear();
  const bool ok = read_kitti_lines(path, "times", "a time in seconds", error, [&](const std::vector<double>& v) -> std::string {
    if (v.size() != 1) return "expected 1 number, got " + std::to_string(v.size());
    if (std::abs(v[0]) > kMaxSeconds) return "time " + std::to_string(v[0]) + " s is out of range (|t| <= 1e11 s)";
    if (!seconds->empty() && v[0] < seconds->back()) return "time goes backwards";
    seconds->push_back(v[0]);
    return {};
  });
  if (!ok) return false;
  if (seconds->empty()) {
    if (error) *error = "times file " + path + " holds no times";
    return false;
  }
  return true;
}

bool read_kitti_calib_tr(const std::string& path, Eigen::Isometry3d* T_cam_velo, std::string* error) {
  std::ifstream in;
  if (std::string reason = text::open_text_file(path, &in); !reason.empty()) {
    if (error) *error = "cannot open calibration file: " + reason;
    return false;
  }
  std::string line, bad;
  std::vector<double> v;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string key = line.substr(0, colon);
    key.erase(0, key.find_first_not_of(" \t"));
    if (key != "Tr" && key != "Tr_velo_to_cam") continue;
    if (!text::parse_numbers(line.substr(colon + 1), &v, &bad, nullptr)) {
      if (error) *error = text::where(path, line_no) + "not a number in " + key + ": '" + bad + "'";
      return false;
    }
    if (v.size() != 12) {
      if (error) *error = text::where(path, line_no) + key + " needs 12 numbers (3x4), got " + std::to_string(v.size());
      return false;
    }
    std::string reason;
    if (!text::checked_isometry_from_3x4(v.data(), T_cam_velo, &reason)) {
      if (error) *error = text::where(path, line_no) + key + ": " + reason;
      return false;
    }
    return true;
  }
  if (error) *error = path + ": no 'Tr:' line (velodyne-to-camera transform)";
  return false;
}

std::vector<Eigen::Isometry3d> kitti_camera_to_lidar(const std::vector<Eigen::Isometry3d>& camera_poses,
                                                     const Eigen::Isometry3d& T_cam_velo) {
  std::vector<Eigen::Isometry3d> out;
  out.reserve(camera_poses.size());
  const Eigen::Isometry3d Tr_inv = T_cam_velo.inverse();
  for (const auto& P : camera_poses) out.push_back(Tr_inv * P * T_cam_velo);
  return out;
}

bool read_kitti_lidar_poses(const std::string& poses_path, const std::string& calib_path,
                            std::vector<Eigen::Isometry3d>* lidar_poses, std::string* error) {
  Eigen::Isometry3d T_cam_velo;
  std::vector<Eigen::Isometry3d> camera_poses;
  if (!read_kitti_calib_tr(calib_path, &T_cam_velo, error) || !read_kitti_poses(poses_path, &camera_poses, error)) return false;
  *lidar_poses = kitti_camera_to_lidar(camera_poses, T_cam_velo);
  return true;
}

}  // namespace loopd
