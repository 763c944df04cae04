#pragma once
/// @file The Prometheus text exposition format (version 0.0.4): "# HELP", "# TYPE" and one sample per metric family.
#include <string>
#include <utility>
#include <vector>

namespace loopd {

/// @brief Builds a /metrics page. Names are loopd_..., with the unit in the name (_bytes, _seconds) and _total on
/// counters, as Prometheus' naming guide asks.
class MetricsText {
 public:
  /// @brief A value that only grows (restarts at 0 with the process).
  void counter(const std::string& name, const std::string& help, double value) { family(name, help, "counter", value, ""); }
  /// @brief A value that goes up and down.
  void gauge(const std::string& name, const std::string& help, double value) { family(name, help, "gauge", value, ""); }
  /// @brief A counter with one sample per value of one label (e.g. per channel).
  void counter(const std::string& name, const std::string& help, const std::string& label,
               const std::vector<std::pair<std::string, double>>& samples);
  /// @brief A gauge with one label (e.g. {device="cpu"} = 1, an "info" metric).
  void gauge(const std::string& name, const std::string& help, double value, const std::string& label, const std::string& label_value);
  const std::string& text() const { return text_; }
  /// @brief The content type scrapers expect for this format.
  static const char* content_type() { return "text/plain; version=0.0.4; charset=utf-8"; }

 private:
  void family(const std::string& name, const std::string& help, const char* type, double value, const std::string& labels);
  void header(const std::string& name, const std::string& help, const char* type);
  void sample(const std::string& name, const std::string& labels, double value);
  std::string text_;
};

}  // namespace loopd
