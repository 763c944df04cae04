#pragma once
// Test-side tools from the npm registry (independent writers of MCAP files and ROS 2 messages): installed once into a
// folder of the build tree, run with Debian's node. Never a dependency of the product; tests skip without them.
#include <string>
#include <vector>

namespace loopd::test {

/// @brief The build tree's folder for npm test tools.
std::string npm_tools_folder();
/// @brief Installs `packages` ("name@version") into npm_tools_folder() unless the first is there; false (the test then
/// skips with a warning) without node, npm, the commands in `also_needed` or the registry.
bool npm_tools(const std::vector<std::string>& packages, const std::vector<std::string>& also_needed = {});
/// @brief Runs test/<script> (copied into npm_tools_folder(), where node finds the modules) with `args`; its exit status.
int run_node(const std::string& script, const std::string& args);

}  // namespace loopd::test
