// loopd-map check: SQLite's integrity check and the map's own invariants.
#include <iostream>
#include <sstream>

#include "map_commands.hpp"
#include "tool_output.hpp"

namespace loopd::tools {

namespace {

const char* const kChecked[] = {
    "SQLite integrity_check (pages, indexes, records)",  "every loop decision names a stored query and match keyframe",
    "keyframe indices run 0..n-1 in each session",       "every keyframe names a stored session",
    "every keyframe of the stored correction is stored",
};

/// @brief The problem lines of a check() message (its first line says how many there are).
std::vector<std::string> problem_lines(const std::string& message) {
  std::vector<std::string> lines;
  std::istringstream in(message);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) lines.push_back(line.substr(line.find_first_not_of(' ')));
  return lines;
}

}  // namespace

int run_check(MapStore& store, const CommandOptions& options) {
  const StoreStatus status = store.check();
  std::cout << "map " << store.uri() << "\nchecked:\n";
  for (const char* what : kChecked) std::cout << "  " << what << "\n";
  const bool ok = status.ok();
  if (ok) {
    std::cout << "OK\n";
  } else {
    std::cout << "FAILED (" << to_string(status.code) << "): " << status.message << "\n";
  }
  if (options.json) {
    nlohmann::json problems = nlohmann::json::array();
    if (!ok) {
      for (const std::string& p : problem_lines(status.message)) problems.push_back(p);
      if (problems.empty()) problems.push_back(status.message);
    }
    print_json_line({{"map", store.uri()}, {"ok", ok}, {"problems", problems}});
  }
  return ok ? kExitOk : kExitCheckFailed;
}

}  // namespace loopd::tools
