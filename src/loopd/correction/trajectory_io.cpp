#include "loopd/correction/trajectory_io.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace loopd {

namespace {

/// Splits a line into numbers; returns false with a reason on a non-number or a non-finite value.
bool parse_numbers(const std::string& line, std::vector<double>& out, std::string& reason) {
  out.clear();
  std::istringstream ss(line);
  std::string tok;
  while (ss >> tok) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') {
      reason = "'" + tok + "' is not a number";
      return false;
    }
    if (!std::isfinite(v)) {
      reason = "non-finite value '" + tok + "'";
      return false;
    }
    out.push_back(v);
  }
  return true;
}

bool skip_line(const std::string& line) {
  const auto p = line.find_first_not_of(" \t\r");
  return p == std::string::npos || line[p] == '#';
}

std::string where(const std::string& source, int line) { return source + ":" + std::to_string(line) + ": "; }

/// 3x4 row-major -> isometry, rejecting matrices that are not (close to) rotations.
bool pose_from_3x4(const double* v, Eigen::Isometry3d& T, std::string& reason) {
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = v[r * 4 + c];
  const double orth = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (orth > 1e-2 || R.determinant() < 0.0) {
    reason = "rotation part is not a rotation matrix (|R^T R - I| = " + std::to_string(orth) + ")";
    return false;
  }
  T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(v[3], v[7], v[11]);
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
  std::string line, reason;
  std::vector<double> v;
  int line_no = 0;
  const std::size_t want = format == TrajectoryFormat::kKitti ? 12 : 8;
  while (std::getline(in, line)) {
    ++line_no;
    if (skip_line(line)) continue;
    if (!parse_numbers(line, v, reason)) {
      f.error = where(source, line_no) + reason;
      return f;
    }
    if (v.size() != want) {
      f.error = where(source, line_no) + "expected " + std::to_string(want) + " numbers (" +
                (format == TrajectoryFormat::kKitti ? "3x4 row-major pose" : "t x y z qx qy qz qw") + "), got " + std::to_string(v.size());
      return f;
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    if (format == TrajectoryFormat::kKitti) {
      if (!pose_from_3x4(v.data(), T, reason)) {
        f.error = where(source, line_no) + reason;
        return f;
      }
      f.stamps.push_back(static_cast<double>(f.poses.size()));
    } else {
      const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
      if (std::abs(q.norm() - 1.0) > 1e-2) {
        f.error = where(source, line_no) + "quaternion is not unit length (|q| = " + std::to_string(q.norm()) + ")";
        return f;
      }
      T.linear() = q.normalized().toRotationMatrix();
      T.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
      f.stamps.push_back(v[0]);
    }
    f.poses.push_back(T);
  }
  if (f.poses.empty()) f.error = source + ": no poses";
  return f;
}

TrajectoryFile read_trajectory(const std::string& path, TrajectoryFormat format) {
  std::ifstream in(path);
  if (!in) {
    TrajectoryFile f;
    f.error = path + ": cannot open";
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

LoopFile parse_loops(std::istream& in, const std::string& source, int num_poses) {
  LoopFile f;
  std::string line, reason;
  std::vector<double> v;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (skip_line(line)) continue;
    if (!parse_numbers(line, v, reason)) {
      f.error = where(source, line_no) + reason;
      return f;
    }
    if (v.size() != 14) {
      f.error = where(source, line_no) + "expected 14 numbers (query_index match_index + 12 of T_match_query), got " + std::to_string(v.size());
      return f;
    }
    LoopConstraint l;
    for (int k = 0; k < 2; ++k) {
      if (v[k] != std::floor(v[k]) || v[k] < 0) {
        f.error = where(source, line_no) + (k == 0 ? "query_index" : "match_index") + std::string(" must be a non-negative integer");
        return f;
      }
      if (num_poses >= 0 && v[k] >= num_poses) {
        f.error = where(source, line_no) + (k == 0 ? "query_index " : "match_index ") + std::to_string(static_cast<long>(v[k])) +
                  " is out of range (trajectory has " + std::to_string(num_poses) + " poses)";
        return f;
      }
    }
    l.query_index = static_cast<int>(v[0]);
    l.match_index = static_cast<int>(v[1]);
    if (!pose_from_3x4(v.data() + 2, l.T_match_query, reason)) {
      f.error = where(source, line_no) + reason;
      return f;
    }
    f.loops.push_back(l);
  }
  return f;
}

LoopFile read_loops(const std::string& path, int num_poses) {
  std::ifstream in(path);
  if (!in) {
    LoopFile f;
    f.error = path + ": cannot open";
    return f;
  }
  return parse_loops(in, path, num_poses);
}

ResidualFile parse_residuals(std::istream& in, const std::string& source) {
  ResidualFile f;
  std::string line, reason;
  std::vector<double> v;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (skip_line(line)) continue;
    if (!parse_numbers(line, v, reason)) {
      f.error = where(source, line_no) + reason;
      return f;
    }
    if (v.size() != 1) {
      f.error = where(source, line_no) + "expected one residual, got " + std::to_string(v.size()) + " numbers";
      return f;
    }
    if (v[0] < 0.0) {
      f.error = where(source, line_no) + "residual must be >= 0";
      return f;
    }
    f.residuals.push_back(v[0]);
  }
  return f;
}

ResidualFile read_residuals(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    ResidualFile f;
    f.error = path + ": cannot open";
    return f;
  }
  return parse_residuals(in, path);
}

}  // namespace loopd
