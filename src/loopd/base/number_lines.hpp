#pragma once
// Line-numbered text files of numbers (trajectories, loops, residuals, KITTI times): one line loop with one set of
// rules, shared by base/trajectory_io, correction/loop_file and io/kitti_files. Errors are "<source>:<line>: <reason>".
#include <Eigen/Geometry>
#include <fstream>
#include <functional>
#include <istream>
#include <optional>
#include <string>
#include <vector>

namespace loopd::text {

/// @brief The numbers of one line, or (ok == false) the first bad token and why.
struct ParsedNumbers {
  std::vector<double> values;
  bool ok = false;
  std::string error;      ///< "'x' is not a number" / "non-finite value 'nan'"
  std::string bad_token;  ///< the token named in error
};
/// @brief Splits a line into numbers; a non-number (a token with a NUL byte inside included) or a non-finite value is
///        an error.
ParsedNumbers parse_numbers(const std::string& line);
/// @brief True for blank lines and '#' comments.
bool skip_line(const std::string& line);
/// @brief "<source>:<line>: ".
std::string where(const std::string& source, int line);
/// @brief Opens a text file for reading: std::nullopt, or "<path>: is a directory, not a file" / "<path>: cannot open".
std::optional<std::string> open_text_file(const std::string& path, std::ifstream* in);

/// @brief Called with the numbers of a line: std::nullopt when the line is fine, else the reason it is not.
using OnNumberLine = std::function<std::optional<std::string>(const std::vector<double>&)>;
/// @brief Reads `in` line by line with the one rule set of loopd's text files: blank lines and lines starting with '#'
///        are skipped; every other line must hold finite numbers only and is passed to on_numbers. Returns
///        std::nullopt, or "<source>:<line>: <reason>" for the first bad line.
std::optional<std::string> for_each_number_line(std::istream& in, const std::string& source, const OnNumberLine& on_numbers);

/// @brief A rigid transform read from 12 numbers, or (ok == false) why they are not one.
struct ParsedIsometry {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  bool ok = false;
  std::string error;
};
/// @brief 3x4 row-major [R | t] (12 values) to an isometry, R re-orthonormalised (files carry 6-9 digits).
Eigen::Isometry3d isometry_from_3x4(const double* v);
/// @brief As isometry_from_3x4, but a rotation part that is not a rotation matrix within 1e-2 (|R^T R - I|_F, and
///        det R > 0) is an error ("rotation part is not a rotation matrix (|R^T R - I| = ...)").
ParsedIsometry checked_isometry_from_3x4(const double* v);

}  // namespace loopd::text
