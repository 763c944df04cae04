#include "support/npm_tools.hpp"

#include "support/process.hpp"

namespace loopd::test {

std::string npm_tools_folder() { return std::string(LOOPD_BINARY_DIR) + "/npm-test-tools"; }

bool npm_tools(const std::vector<std::string>& packages, const std::vector<std::string>& also_needed) {
  std::string commands = "command -v node && command -v npm";
  for (const std::string& c : also_needed) commands += " && command -v " + c;
  if (run_quiet(commands) != 0) return false;
  const std::string first = packages.empty() ? "" : packages.front().substr(0, packages.front().rfind('@'));
  if (!first.empty() && run_quiet("test -d " + npm_tools_folder() + "/node_modules/" + first) == 0) return true;
  // Under a lock: ctest runs two tests at once, and two installs into one folder would tread on each other.
  run_quiet("mkdir -p " + npm_tools_folder());
  std::string install = "flock " + npm_tools_folder() + "/.lock timeout 120 npm install --no-audit --no-fund --prefix " + npm_tools_folder();
  for (const std::string& p : packages) install += " " + p;
  return run_quiet(install) == 0;
}

int run_node(const std::string& script, const std::string& args) {
  const std::string name = script.substr(script.rfind('/') + 1);
  return run_quiet("cp " + std::string(LOOPD_SOURCE_DIR) + "/test/" + script + " " + npm_tools_folder() + "/ && node " + npm_tools_folder() + "/" +
                   name + " " + args);
}

}  // namespace loopd::test
