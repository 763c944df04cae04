#pragma once
/// @file The YAML config's one field list, used twice: a Binder walks every field once, loading it from YAML or dumping
/// it (load_config, dump_config). Each config's fields are bound next to it: bind(Binder&, NodeConfig&) in
/// node_config.cpp, bind(Binder&, EngineConfig&) in engine_config_bind.cpp, bind(Binder&, LoopDetectorConfig&, ...) in
/// detector_config_bind.cpp.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace loopd {

/// @brief Walks every config field once, either loading it from YAML or dumping it (one list of fields, two uses).
class Binder {
 public:
  enum class Mode { kLoad, kDump };
  Binder(Mode mode, YAML::Node root) : mode_(mode), root_(std::move(root)) {}

  template <typename T>
  void field(const std::string& path, T& value) {
    known_.insert(path);
    if (mode_ == Mode::kDump) {
      dump_[path] = {to_text(value), std::is_same_v<T, std::string>};
      return;
    }
    if (!error_.empty()) return;
    YAML::Node node = lookup(path);
    if (!node) return;
    try {
      const T parsed = node.as<T>();
      if constexpr (std::is_same_v<T, std::vector<double>>) {
        if (!std::all_of(parsed.begin(), parsed.end(), [](double x) { return std::isfinite(x); })) {
          error_ = at(node) + path + ": expected finite numbers";
          return;
        }
      }
      if constexpr (std::is_floating_point_v<T>) {
        if (!std::isfinite(parsed)) {
          error_ = at(node) + path + ": expected a finite number, got '" + node.Scalar().substr(0, 64) + "'";
          return;
        }
      }
      value = parsed;
    } catch (const YAML::Exception&) {
      error_ = at(node) + path + ": expected " + type_name(value) + ", got '" +
               (node.IsScalar() ? node.Scalar().substr(0, 64) : std::string("a map or list")) + "'";
    }
  }
  /// An enum stored as one of several names.
  template <typename E>
  void choice(const std::string& path, E& value, const std::vector<std::pair<std::string, E>>& names) {
    std::string text;
    for (const auto& [n, v] : names)
      if (v == value) text = n;
    known_.insert(path);
    if (mode_ == Mode::kDump) {
      dump_[path] = {text, false};
      return;
    }
    if (!error_.empty()) return;
    YAML::Node node = lookup(path);
    if (!node) return;
    const std::string got = node.IsScalar() ? node.Scalar().substr(0, 64) : "";
    for (const auto& [n, v] : names)
      if (n == got) {
        value = v;
        return;
      }
    std::string options;
    for (const auto& [n, v] : names) options += (options.empty() ? "" : ", ") + n;
    error_ = at(node) + path + ": expected one of " + options + ", got '" + got + "'";
  }
  /// Reports keys present in the YAML that no field consumed.
  void check_unknown() {
    if (!error_.empty() || mode_ != Mode::kLoad) return;
    walk(root_, "");
  }
  const std::string& error() const { return error_; }
  /// Dumped values: path -> (YAML text, whether it is a string).
  const std::map<std::string, std::pair<std::string, bool>>& dumped() const { return dump_; }

 private:
  /// "line N: " of a node (1-based), "" when yaml-cpp has no position for it.
  static std::string at(const YAML::Node& node) {
    const YAML::Mark m = node.Mark();
    return m.is_null() ? std::string() : "line " + std::to_string(m.line + 1) + ": ";
  }
  YAML::Node lookup(const std::string& path) const {
    // Read-only walk: const operator[] inserts nothing, and reset() re-points the handle (operator= would overwrite
    // the node it refers to).
    YAML::Node node;
    node.reset(root_);
    std::stringstream ss(path);
    std::string part;
    while (std::getline(ss, part, '.')) {
      if (!node.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
      const YAML::Node& map = node;
      YAML::Node child = map[part];
      if (!child) return YAML::Node(YAML::NodeType::Undefined);
      node.reset(child);
    }
    return node;
  }
  void walk(const YAML::Node& node, const std::string& prefix) {
    if (!error_.empty()) return;
    if (!node.IsMap()) {
      if (!prefix.empty() && !known_.count(prefix)) error_ = prefix + ": unknown configuration key";
      return;
    }
    for (const auto& kv : node) {
      if (!kv.first.IsScalar()) {
        error_ = at(kv.first) + (prefix.empty() ? std::string() : prefix + ": ") + "a key must be a plain name, not a map or list";
        return;
      }
      const std::string key = prefix.empty() ? kv.first.Scalar() : prefix + "." + kv.first.Scalar();
      walk(kv.second, key);
    }
  }
  static std::string type_name(const double&) { return "a number"; }
  static std::string type_name(const int&) { return "an integer"; }
  static std::string type_name(const std::int64_t&) { return "an integer"; }
  static std::string type_name(const bool&) { return "true or false"; }
  static std::string type_name(const std::string&) { return "a string"; }
  static std::string type_name(const std::vector<double>&) { return "a list of numbers"; }
  /// The shortest decimal text (6 to 17 digits) that reads back as exactly `v`.
  static std::string shortest_exact(double v) {
    std::string text;
    for (int digits = 6; digits <= 17; ++digits) {
      std::ostringstream os;
      os << std::setprecision(digits) << v;
      text = os.str();
      if (std::strtod(text.c_str(), nullptr) == v) break;
    }
    return text;
  }
  template <typename T>
  static std::string to_text(const T& v) {
    std::ostringstream os;
    if constexpr (std::is_same_v<T, bool>)
      os << (v ? "true" : "false");
    else if constexpr (std::is_same_v<T, std::string>)
      os << v;  // emitted as a string node (quoted by the emitter where needed)
    else if constexpr (std::is_floating_point_v<T>)
      os << shortest_exact(v);  // loads back to the same double
    else if constexpr (std::is_same_v<T, std::vector<double>>) {
      os << "[";
      for (std::size_t i = 0; i < v.size(); ++i) os << (i ? ", " : "") << shortest_exact(v[i]);
      os << "]";
    } else
      os << v;
    return os.str();
  }

  Mode mode_;
  YAML::Node root_;
  std::set<std::string> known_;
  std::map<std::string, std::pair<std::string, bool>> dump_;
  std::string error_;
};

struct NodeConfig;
struct EngineConfig;
struct LoopDetectorConfig;
struct SessionPolicy;
/// @brief The fields of each config, by their YAML path (node_config.cpp, engine_config_bind.cpp, detector_config_bind.cpp).
void bind(Binder& b, NodeConfig& node);
void bind(Binder& b, EngineConfig& engine);
void bind(Binder& b, LoopDetectorConfig& detector, SessionPolicy& sessions);

}  // namespace loopd
