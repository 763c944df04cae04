#include "loopd/base/trajectory_io.hpp"

#include <cmath>
#include <fstream>
#include <iomanip>

#include "loopd/base/number_lines.hpp"

namespace loopd {

namespace {

/// One KITTI line: 12 numbers, the 3x4 row-major [R | t].
std::optional<std::string> add_kitti_pose(const std::vector<double>& v, TrajectoryFile* f) {
  if (v.size() != 12) return "expected 12 numbers (3x4 row-major pose), got " + std::to_string(v.size());
  const text::ParsedIsometry T = text::checked_isometry_from_3x4(v.data());
  if (!T.ok) return T.error;
  f->stamps.push_back(static_cast<double>(f->poses.size()));
  f->poses.push_back(T.T);
  return std::nullopt;
}

/// One TUM line: `t x y z qx qy qz qw`.
std::optional<std::string> add_tum_pose(const std::vector<double>& v, TrajectoryFile* f) {
  if (v.size() != 8) return "expected 8 numbers (t x y z qx qy qz qw), got " + std::to_string(v.size());
  const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
  if (std::abs(q.norm() - 1.0) > 1e-2) return "quaternion is not unit length (|q| = " + std::to_string(q.norm()) + ")";
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
  f->stamps.push_back(v[0]);
  f->poses.push_back(T);
  return std::nullopt;
}

}  // namespace

std::optional<TrajectoryFormat> trajectory_format_from_string(const std::string& name) {
  if (name == "kitti") return TrajectoryFormat::kKitti;
  if (name == "tum") return TrajectoryFormat::kTum;
  return std::nullopt;
}

TrajectoryFile parse_trajectory(std::istream& in, TrajectoryFormat format, const std::string& source) {
  TrajectoryFile f;
  const auto error = text::for_each_number_line(
      in, source, [&](const std::vector<double>& v) { return format == TrajectoryFormat::kKitti ? add_kitti_pose(v, &f) : add_tum_pose(v, &f); });
  if (error) {
    f.error = *error;
  } else if (f.poses.empty()) {
    f.error = source + ": no poses";
  } else {
    f.ok = true;
  }
  return f;
}

TrajectoryFile read_trajectory(const std::string& path, TrajectoryFormat format) {
  std::ifstream in;
  if (auto reason = text::open_text_file(path, &in)) {
    TrajectoryFile f;
    f.error = *reason;
    return f;
  }
  return parse_trajectory(in, format, path);
}

std::optional<std::string> write_trajectory(const std::string& path, const std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& stamps,
                                            TrajectoryFormat format) {
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

}  // namespace loopd
