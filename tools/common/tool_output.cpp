#include "tool_output.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <unistd.h>

namespace loopd::tools {
namespace {
double now_s() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
std::int64_t read_status_kb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::string k(key);
  while (std::getline(in, line))
    if (line.compare(0, k.size(), k) == 0) return std::atoll(line.c_str() + k.size() + 1) * 1024;
  return 0;
}
}  // namespace

Progress::Progress(std::string label, std::int64_t total, bool enabled)
    : label_(std::move(label)), total_(total), enabled_(enabled), start_(now_s()) {}

void Progress::update(std::int64_t done) {
  if (!enabled_) return;
  const double t = now_s();
  const bool tty = isatty(fileno(stderr));
  // A terminal gets a bar redrawn in place at most 10 times a second; a log file a line every 10 % or 10 s.
  const std::int64_t step = std::max<std::int64_t>(1, total_ / 10);
  if (done < total_ && (tty ? t - last_draw_ < 0.1 : (done / step == last_step_ && t - last_draw_ < 10.0))) return;
  if (!tty && done >= total_ && last_step_ == done / step && last_draw_ >= 0) return;
  last_draw_ = t;
  last_step_ = done / step;
  constexpr int kWidth = 30;
  const double frac = total_ > 0 ? std::min(1.0, static_cast<double>(done) / static_cast<double>(total_)) : 0.0;
  const int filled = static_cast<int>(frac * kWidth);
  std::string bar(static_cast<std::size_t>(filled), '=');
  if (filled < kWidth) bar += '>';
  bar.resize(kWidth, ' ');
  std::fprintf(stderr, "%s%s [%s] %lld/%lld %.1f s%s", tty ? "\r" : "", label_.c_str(), bar.c_str(), static_cast<long long>(done),
               static_cast<long long>(total_), t - start_, tty ? "" : "\n");
  std::fflush(stderr);
}

void Progress::finish() {
  if (!enabled_) return;
  last_draw_ = -1.0;
  update(total_);
  if (isatty(fileno(stderr))) std::fprintf(stderr, "\n");
}

std::string Table::str() const {
  std::vector<std::size_t> w(header_.size(), 0);
  auto widen = [&](const std::vector<std::string>& r) {
    for (std::size_t i = 0; i < r.size() && i < w.size(); ++i) w[i] = std::max(w[i], r[i].size());
  };
  widen(header_);
  for (const auto& r : rows_) widen(r);
  std::ostringstream os;
  auto line = [&](const std::vector<std::string>& r) {
    for (std::size_t i = 0; i < w.size(); ++i) {
      const std::string cell = i < r.size() ? r[i] : "";
      os << cell << std::string(w[i] - cell.size() + 2, ' ');
    }
    os << "\n";
  };
  line(header_);
  std::size_t total = 0;
  for (auto x : w) total += x + 2;
  os << std::string(total, '-') << "\n";
  for (const auto& r : rows_) line(r);
  return os.str();
}

std::string fmt(double v, int precision) {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", precision, v);
  return buf;
}

void print_json_line(const nlohmann::json& j) { std::cout << j.dump() << std::endl; }

Summary summarize(std::vector<double> v) {
  Summary s;
  s.count = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  auto q = [&](double p) {
    return v[std::min(v.size() - 1, static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size()))) - (p > 0 ? 1 : 0))];
  };
  s.median = v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  s.p95 = q(0.95);
  s.max = v.back();
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / static_cast<double>(v.size());
  return s;
}

std::int64_t peak_rss_bytes() { return read_status_kb("VmHWM:"); }
std::int64_t current_rss_bytes() { return read_status_kb("VmRSS:"); }

}  // namespace loopd::tools
