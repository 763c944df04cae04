#include "loopd/runtime/daemon_config.hpp"
#include "loopd/runtime/config_binder.hpp"
#include "loopd/records/vehicle_sessions.hpp"
#include "loopd/store/store_uri.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

namespace loopd {
namespace {

/// Every field of loopd's config: the node's, then the engine's (with the detector's).
void bind(Binder& b, DaemonConfig& c) {
  bind(b, c.node);
  bind(b, c.engine);
}

}  // namespace

bool apply_sensor_preset(const std::string& sensor, DaemonConfig* config, std::string* error) {
  if (sensor == "custom") {  // its table comes with the config's sensor_elevations_deg (checked by validate)
    config->engine.detector.sensor = sensor;
    return true;
  }
  if (auto e = validate_sensor_choice(sensor)) {
    *error = *e;
    return false;
  }
  config->engine.detector.sensor = sensor;
  return true;
}

namespace {

bool load_config_text_unguarded(const std::string& yaml, DaemonConfig* config, std::string* error) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& ex) {
    *error = std::string("YAML syntax: ") + ex.what();
    return false;
  }
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) {
    *error = "the config must be a YAML map of keys";
    return false;
  }
  // The sensor preset first, so explicit keys override what it implies.
  if (root["sensor"] && root["sensor"].IsScalar() && !apply_sensor_preset(root["sensor"].Scalar(), config, error)) return false;
  Binder b(Binder::Mode::kLoad, root);
  bind(b, *config);
  b.check_unknown();
  if (!b.error().empty()) {
    *error = b.error();
    return false;
  }
  if (auto e = config->node.validate()) {
    *error = *e;
    return false;
  }
  if (auto e = config->engine.validate()) {
    *error = *e;
    return false;
  }
  return true;
}

/// A config file is small text: anything larger is not one (and /dev/zero never ends).
constexpr std::uintmax_t kMaxConfigBytes = 1 << 20;

}  // namespace

bool load_config_text(const std::string& yaml, DaemonConfig* config, std::string* error) {
  // yaml-cpp reports bad YAML with exceptions, some from places the binder cannot foresee (conversions, node
  // access): none may leave here. The config is only changed when the whole text is accepted.
  DaemonConfig candidate = *config;
  try {
    if (!load_config_text_unguarded(yaml, &candidate, error)) return false;
  } catch (const std::exception& ex) {
    *error = std::string("YAML: ") + ex.what();
    return false;
  }
  *config = candidate;
  return true;
}

bool load_config(const std::string& path, DaemonConfig* config, std::string* error) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) {
    *error = "cannot read config file " + path + " (no such file)";
    return false;
  }
  if (!std::filesystem::is_regular_file(status)) {
    *error = "cannot read config file " + path + (std::filesystem::is_directory(status) ? " (a directory)" : " (not a regular file)");
    return false;
  }
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec || size > kMaxConfigBytes) {
    *error = "config file " + path + " is " + std::to_string(size) + " bytes (at most " + std::to_string(kMaxConfigBytes) + ")";
    return false;
  }
  std::ifstream in(path);
  if (!in) {
    *error = "cannot read config file " + path;
    return false;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  if (!load_config_text(ss.str(), config, error)) {
    *error = path + ": " + *error;
    return false;
  }
  return true;
}

std::string dump_config(const DaemonConfig& config) {
  DaemonConfig copy = config;
  Binder b(Binder::Mode::kDump, YAML::Node());
  bind(b, copy);
  // Nest the dotted paths back into YAML.
  YAML::Node root(YAML::NodeType::Map);
  for (const auto& [path, value] : b.dumped()) {
    const std::string& text = value.first;  // (a lambda cannot capture structured bindings in C++17)
    const bool is_string = value.second;
    std::vector<std::string> parts;
    std::stringstream ss(path);
    std::string part;
    while (std::getline(ss, part, '.')) parts.push_back(part);
    std::function<void(YAML::Node, std::size_t)> set = [&](YAML::Node node, std::size_t i) {
      if (i + 1 == parts.size()) {
        if (is_string)
          node[parts[i]] = text;
        else
          node[parts[i]] = YAML::Load(text);
        return;
      }
      set(node[parts[i]], i + 1);
    };
    set(root, 0);
  }
  YAML::Emitter out;
  out << root;
  return std::string(out.c_str()) + "\n";
}

void apply_fleet(DaemonConfig* config) {
  NodeConfig& n = config->node;
  if (names_shared_map(n.map.uri) && n.fleet.vehicle < 0) n.fleet.vehicle = 0;
  n.map.vehicle = n.fleet.vehicle;
  config->engine.sessions.first_session = first_session_of(n.fleet.vehicle);
}

}  // namespace loopd
