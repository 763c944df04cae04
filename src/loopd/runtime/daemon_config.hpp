#pragma once
#include <optional>
#include <string>

#include "loopd/runtime/node_config.hpp"
#include "loopd/runtime/loopd_engine.hpp"

namespace loopd {

/// @brief Everything loopd reads from its YAML config (see daemon/loopd.example.yaml).
struct DaemonConfig {
  NodeConfig node;
  EngineConfig engine;
};

/// @brief Applies a sensor preset (vlp16, hdl32, hdl64, os1-64) to the detector settings it implies.
bool apply_sensor_preset(const std::string& sensor, DaemonConfig* config, std::string* error);

/// @brief Reads a YAML config over the defaults. Unknown keys and wrong values are errors that name the field
///        (e.g. "gate.min_radius: expected a number, got 'abc'"). Validates the result.
bool load_config(const std::string& path, DaemonConfig* config, std::string* error);
/// @brief Same, from YAML text.
bool load_config_text(const std::string& yaml, DaemonConfig* config, std::string* error);

/// @brief A shared (postgresql://) map makes this process a fleet vehicle (0 unless fleet.vehicle says): the map store is
/// scoped to the vehicle and its sessions are numbered from vehicle * kSessionsPerVehicle. Call after every override.
void apply_fleet(DaemonConfig* config);

/// @brief The whole effective configuration as YAML (for --print-config).
std::string dump_config(const DaemonConfig& config);

}  // namespace loopd
