#include "loopd/correction/trajectory_io.hpp"

#include <cmath>
#include <fstream>

namespace loopd {

LoopFile parse_loops(std::istream& in, const std::string& source, int num_poses) {
  LoopFile f;
  f.error = text::for_each_number_line(in, source, [&](const std::vector<double>& v) -> std::string {
    if (v.size() != 14) return "expected 14 numbers (query_index match_index + 12 of T_match_query), got " + std::to_string(v.size());
    for (int k = 0; k < 2; ++k) {
      if (v[k] != std::floor(v[k]) || v[k] < 0) return (k == 0 ? "query_index" : "match_index") + std::string(" must be a non-negative integer");
      if (num_poses >= 0 && v[k] >= num_poses)
        return (k == 0 ? "query_index " : "match_index ") + std::to_string(static_cast<long>(v[k])) + " is out of range (trajectory has " +
               std::to_string(num_poses) + " poses)";
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
  f.error = text::for_each_number_line(in, source, [&](const std::vector<double>& v) -> std::string {
    if (v.size() != 1) return "expected one residual, got " + std::to_string(v.size()) + " numbers";
    if (v[0] < 0.0) return "residual must be >= 0";
    f.residuals.push_back(v[0]);
    return {};
  });
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
