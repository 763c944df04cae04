#include "loopd/correction/trajectory_io.hpp"

#include <cmath>
#include <fstream>
#include <limits>

namespace loopd {

LoopFile parse_loops(std::istream& in, const std::string& source, int num_poses) {
  LoopFile f;
  f.error = text::for_each_number_line(in, source, [&](const std::vector<double>& v) -> std::string {
    if (v.size() != 14) return "expected 14 numbers (query_index match_index + 12 of T_match_query), got " + std::to_string(v.size());
    for (int k = 0; k < 2; ++k) {
      const std::string name = k == 0 ? "query_index" : "match_index";
      if (v[k] != std::floor(v[k]) || v[k] < 0) return name + " must be a non-negative integer";
      if (v[k] > static_cast<double>(std::numeric_limits<int>::max())) return name + " " + std::to_string(v[k]) + " is out of range";
      if (num_poses >= 0 && v[k] >= num_poses)
        return name + " " + std::to_string(static_cast<long>(v[k])) + " is out of range (trajectory has " + std::to_string(num_poses) + " poses)";
    }
    LoopConstraint l;
    l.query_index = static_cast<int>(v[0]);
    l.match_index = static_cast<int>(v[1]);
    std::string reason;
    if (!text::checked_isometry_from_3x4(v.data() + 2, &l.T_match_query, &reason)) return reason;
    f.loops.push_back(l);
    return {};
  });
  return f;
}

LoopFile read_loops(const std::string& path, int num_poses) {
  std::ifstream in;
  if (std::string reason = text::open_text_file(path, &in); !reason.empty()) {
    LoopFile f;
    f.error = reason;
    return f;
  }
  return parse_loops(in, path, num_poses);
}

ResidualFile parse_residuals(std::istream& in, const std::string& source) {
  ResidualFile f;
  f.error = text::for_each_number_line(in, source, [&](const std::vector<double>& v) -> std::string {
    if (v.size() != 1) return "expected one residual, got " + std::to_string(v.size()) + " numbers";
    if (v[0] < 0.0) return "residual must be >= 0";
    f.residuals.push_back(v[0]);
    return {};
  });
  return f;
}

ResidualFile read_residuals(const std::string& path) {
  std::ifstream in;
  if (std::string reason = text::open_text_file(path, &in); !reason.empty()) {
    ResidualFile f;
    f.error = reason;
    return f;
  }
  return parse_residuals(in, path);
}

}  // namespace loopd
