#include "loopd/base/number_lines.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

namespace loopd::text {

ParsedNumbers parse_numbers(const std::string& line) {
  ParsedNumbers p;
  std::istringstream ss(line);
  std::string tok;
  while (ss >> tok) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || end != tok.c_str() + tok.size()) {  // also a token with a NUL byte inside
      p.bad_token = tok;
      p.error = "'" + tok + "' is not a number";
      return p;
    }
    if (!std::isfinite(v)) {
      p.bad_token = tok;
      p.error = "non-finite value '" + tok + "'";
      return p;
    }
    p.values.push_back(v);
  }
  p.ok = true;
  return p;
}

bool skip_line(const std::string& line) {
  const auto p = line.find_first_not_of(" \t\r");
  return p == std::string::npos || line[p] == '#';
}

std::string where(const std::string& source, int line) { return source + ":" + std::to_string(line) + ": "; }

std::optional<std::string> open_text_file(const std::string& path, std::ifstream* in) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return path + ": is a directory, not a file";
  in->open(path);
  if (!*in) return path + ": cannot open";
  return std::nullopt;
}

std::optional<std::string> for_each_number_line(std::istream& in, const std::string& source, const OnNumberLine& on_numbers) {
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (skip_line(line)) continue;
    const ParsedNumbers numbers = parse_numbers(line);
    if (!numbers.ok) return where(source, line_no) + numbers.error;
    if (auto reason = on_numbers(numbers.values)) return where(source, line_no) + *reason;
  }
  return std::nullopt;
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

ParsedIsometry checked_isometry_from_3x4(const double* v) {
  ParsedIsometry p;
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = v[r * 4 + c];
  const double orth = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  // Written so that NaN (from huge values that overflow) fails too.
  if (!(orth <= 1e-2) || !(R.determinant() > 0.0)) {
    p.error = "rotation part is not a rotation matrix (|R^T R - I| = " + std::to_string(orth) + ")";
    return p;
  }
  p.T = isometry_from_3x4(v);
  p.ok = true;
  return p;
}

}  // namespace loopd::text
