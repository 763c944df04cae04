#include "loopd/correction/loop_file.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <optional>

#include "loopd/base/number_lines.hpp"

namespace loopd {

namespace {

/// query_index (k = 0) or match_index (k = 1) of a loop line: a non-negative int, below num_poses when that is >= 0.
std::optional<std::string> check_loop_index(const std::vector<double>& v, int k, int num_poses) {
  const std::string name = k == 0 ? "query_index" : "match_index";
  const double value = v[static_cast<std::size_t>(k)];
  if (value != std::floor(value) || value < 0) return name + " must be a non-negative integer";
  if (value > static_cast<double>(std::numeric_limits<int>::max())) return name + " " + std::to_string(value) + " is out of range";
  if (num_poses >= 0 && value >= num_poses)
    return name + " " + std::to_string(static_cast<long>(value)) + " is out of range (trajectory has " + std::to_string(num_poses) + " poses)";
  return std::nullopt;
}

/// The result of a reader given a path: the file opened, or the result carrying why not.
template <typename File, typename Parse>
File read_text(const std::string& path, Parse parse) {
  std::ifstream in;
  if (auto reason = text::open_text_file(path, &in)) {
    File f;
    f.error = *reason;
    return f;
  }
  return parse(in);
}

}  // namespace

LoopFile parse_loops(std::istream& in, const std::string& source, int num_poses) {
  LoopFile f;
  const auto error = text::for_each_number_line(in, source, [&](const std::vector<double>& v) -> std::optional<std::string> {
    if (v.size() != 14) return "expected 14 numbers (query_index match_index + 12 of T_match_query), got " + std::to_string(v.size());
    for (int k = 0; k < 2; ++k)
      if (auto reason = check_loop_index(v, k, num_poses)) return reason;
    const text::ParsedIsometry T = text::checked_isometry_from_3x4(v.data() + 2);
    if (!T.ok) return T.error;
    LoopConstraint l;
    l.query_index = static_cast<int>(v[0]);
    l.match_index = static_cast<int>(v[1]);
    l.T_match_query = T.T;
    f.loops.push_back(l);
    return std::nullopt;
  });
  f.ok = !error;
  if (error) f.error = *error;
  return f;
}

LoopFile read_loops(const std::string& path, int num_poses) {
  return read_text<LoopFile>(path, [&](std::istream& in) { return parse_loops(in, path, num_poses); });
}

ResidualFile parse_residuals(std::istream& in, const std::string& source) {
  ResidualFile f;
  const auto error = text::for_each_number_line(in, source, [&](const std::vector<double>& v) -> std::optional<std::string> {
    if (v.size() != 1) return "expected one residual, got " + std::to_string(v.size()) + " numbers";
    if (v[0] < 0.0) return "residual must be >= 0";
    f.residuals.push_back(v[0]);
    return std::nullopt;
  });
  f.ok = !error;
  if (error) f.error = *error;
  return f;
}

ResidualFile read_residuals(const std::string& path) {
  return read_text<ResidualFile>(path, [&](std::istream& in) { return parse_residuals(in, path); });
}

}  // namespace loopd
