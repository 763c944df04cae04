#include "loopd/eval/trajectory_io.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace loopd {
namespace {

bool parse_numbers(const std::string& text, std::vector<double>* out, std::string* bad_token) {
  out->clear();
  std::istringstream in(text);
  std::string tok;
  while (in >> tok) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0' || !std::isfinite(v)) {
      *bad_token = tok;
      return false;
    }
    out->push_back(v);
  }
  return true;
}

Eigen::Isometry3d isometry_from_3x4(const std::vector<double>& v) {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R(r, c) = v[static_cast<std::size_t>(r * 4 + c)];
    t(r) = v[static_cast<std::size_t>(r * 4 + 3)];
  }
  // Re-orthonormalise: KITTI files carry 6-9 significant digits.
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  T.translation() = t;
  return T;
}

bool is_blank(const std::string& s) { return s.find_first_not_of(" \t\r") == std::string::npos; }

}  // namespace

bool write_tum_trajectory(const std::string& path, const std::vector<std::int64_t>& utimes,
                          const std::vector<Eigen::Isometry3d>& poses, std::string* error) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    if (error) *error = "cannot write " + path;
    return false;
  }
  const std::size_t n = std::min(utimes.size(), poses.size());
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Quaterniond q(poses[i].linear());
    const Eigen::Vector3d t = poses[i].translation();
    std::fprintf(f, "%.6f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", static_cast<double>(utimes[i]) * 1e-6, t.x(), t.y(),
                 t.z(), q.x(), q.y(), q.z(), q.w());
  }
  return std::fclose(f) == 0;
}

bool write_kitti_trajectory(const std::string& path, const std::vector<Eigen::Isometry3d>& poses, std::string* error) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    if (error) *error = "cannot write " + path;
    return false;
  }
  for (const auto& T : poses) {
    const Eigen::Matrix4d M = T.matrix();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) std::fprintf(f, "%.9e%s", M(r, c), (r == 2 && c == 3) ? "\n" : " ");
  }
  return std::fclose(f) == 0;
}

bool read_kitti_poses(const std::string& path, std::vector<Eigen::Isometry3d>* poses, std::string* error) {
  poses->clear();
  std::ifstream in(path);
  if (!in) {
    if (error) *error = "cannot open poses file " + path;
    return false;
  }
  std::string line, bad;
  std::vector<double> v;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (is_blank(line)) {
      // A trailing empty line is harmless; an empty line in the middle would shift every later pose.
      if (in.peek() == EOF) break;
      if (error) *error = path + ":" + std::to_string(line_no) + ": empty line (expected 12 numbers)";
      return false;
    }
    if (!parse_numbers(line, &v, &bad)) {
      if (error) *error = path + ":" + std::to_string(line_no) + ": not a number: '" + bad + "'";
      return false;
    }
    if (v.size() != 12) {
      if (error)
        *error = path + ":" + std::to_string(line_no) + ": expected 12 numbers (3x4 pose), got " + std::to_string(v.size());
      return false;
    }
    poses->push_back(isometry_from_3x4(v));
  }
  if (poses->empty()) {
    if (error) *error = "poses file " + path + " holds no poses";
    return false;
  }
  return true;
}

bool read_kitti_times(const std::string& path, std::vector<double>* seconds, std::string* error) {
  seconds->clear();
  std::ifstream in(path);
  if (!in) {
    if (error) *error = "cannot open times file " + path;
    return false;
  }
  std::string line, bad;
  std::vector<double> v;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (is_blank(line)) {
      if (in.peek() == EOF) break;
      if (error) *error = path + ":" + std::to_string(line_no) + ": empty line (expected a time in seconds)";
      return false;
    }
    if (!parse_numbers(line, &v, &bad)) {
      if (error) *error = path + ":" + std::to_string(line_no) + ": not a number: '" + bad + "'";
      return false;
    }
    if (v.size() != 1) {
      if (error) *error = path + ":" + std::to_string(line_no) + ": expected 1 number, got " + std::to_string(v.size());
      return false;
    }
    if (!seconds->empty() && v[0] < seconds->back()) {
      if (error) *error = path + ":" + std::to_string(line_no) + ": time goes backwards";
      return false;
    }
    seconds->push_back(v[0]);
  }
  if (seconds->empty()) {
    if (error) *error = "times file " + path + " holds no times";
    return false;
  }
  return true;
}

bool read_kitti_calib_tr(const std::string& path, Eigen::Isometry3d* T_cam_velo, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    if (error) *error = "cannot open calibration file " + path;
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
    if (!parse_numbers(line.substr(colon + 1), &v, &bad)) {
      if (error) *error = path + ":" + std::to_string(line_no) + ": not a number in " + key + ": '" + bad + "'";
      return false;
    }
    if (v.size() != 12) {
      if (error)
        *error = path + ":" + std::to_string(line_no) + ": " + key + " needs 12 numbers (3x4), got " + std::to_string(v.size());
      return false;
    }
    *T_cam_velo = isometry_from_3x4(v);
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

}  // namespace loopd
