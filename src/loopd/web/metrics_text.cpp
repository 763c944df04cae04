#include "loopd/web/metrics_text.hpp"

#include <cmath>
#include <cstdio>

namespace loopd {
namespace {

std::string number(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  char buf[32];
  if (v == std::floor(v) && std::fabs(v) < 9.007199254740992e15)  // an integer: exactly, no exponent
    std::snprintf(buf, sizeof buf, "%.0f", v);
  else
    std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

/// HELP text: backslash and newline escaped. Label values also escape the double quote.
std::string escaped(const std::string& s, bool quote) {
  std::string out;
  for (char c : s) {
    if (c == '\\')
      out += "\\\\";
    else if (c == '\n')
      out += "\\n";
    else if (quote && c == '"')
      out += "\\\"";
    else
      out += c;
  }
  return out;
}

std::string label_text(const std::string& label, const std::string& value) { return "{" + label + "=\"" + escaped(value, true) + "\"}"; }

}  // namespace

void MetricsText::counter(const std::string& name, const std::string& help, const std::string& label,
                          const std::vector<std::pair<std::string, double>>& samples) {
  header(name, help, "counter");
  for (const auto& [value_of_label, value] : samples) sample(name, label_text(label, value_of_label), value);
}

void MetricsText::gauge(const std::string& name, const std::string& help, double value, const std::string& label, const std::string& label_value) {
  family(name, help, "gauge", value, label_text(label, label_value));
}

void MetricsText::family(const std::string& name, const std::string& help, const char* type, double value, const std::string& labels) {
  header(name, help, type);
  sample(name, labels, value);
}

void MetricsText::header(const std::string& name, const std::string& help, const char* type) {
  text_ += "# HELP " + name + " " + escaped(help, false) + "\n";
  text_ += "# TYPE " + name + " " + type + "\n";
}

void MetricsText::sample(const std::string& name, const std::string& labels, double value) { text_ += name + labels + " " + number(value) + "\n"; }

}  // namespace loopd
