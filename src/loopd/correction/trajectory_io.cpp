#include "loopd/correction/trajectory_io.hpp"

#include <cmath>
#include <fstream>

namespace loopd {

using text::where;

LoopFile parse_loops(std::istream& in, const std::string& source, int num_poses) {
  LoopFile f;
  std::string line, reason;
  std::vector<double> v;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (text::skip_line(line)) continue;
    if (!text::parse_numbers(line, &v, nullptr, &reason)) {
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
    if (!text::checked_isometry_from_3x4(v.data() + 2, &l.T_match_query, &reason)) {
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
    if (text::skip_line(line)) continue;
    if (!text::parse_numbers(line, &v, nullptr, &reason)) {
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
