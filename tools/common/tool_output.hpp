#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace loopd::tools {

/// @brief Progress bar on stderr ("label [=====>    ] 42/100 3.1 s"), redrawn at most 10 times a second.
class Progress {
 public:
  Progress(std::string label, std::int64_t total, bool enabled = true);
  void update(std::int64_t done);
  void finish();

 private:
  std::string label_;
  std::int64_t total_;
  bool enabled_;
  double last_draw_ = -1.0;
  std::int64_t last_step_ = -1;
  double start_;
};

/// @brief A plain-text table: header row, then rows; columns padded to their widest cell.
class Table {
 public:
  explicit Table(std::vector<std::string> header) : header_(std::move(header)) {}
  void add(std::vector<std::string> row) { rows_.push_back(std::move(row)); }
  std::string str() const;

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

/// @brief Number formatted with `precision` digits after the point.
std::string fmt(double v, int precision = 3);

/// @brief Prints the JSON object as the last line of stdout (the project's --json convention).
void print_json_line(const nlohmann::json& j);

/// @brief Median, p95 and max of a sample (0 when empty).
struct Summary {
  double median = 0, p95 = 0, max = 0, mean = 0;
  std::size_t count = 0;
};
Summary summarize(std::vector<double> v);

/// @brief Peak resident memory of this process [bytes] (VmHWM), 0 when unknown.
std::int64_t peak_rss_bytes();
/// @brief Current resident memory of this process [bytes] (VmRSS), 0 when unknown.
std::int64_t current_rss_bytes();

}  // namespace loopd::tools
