#include "support/data_dir.hpp"

#include <cstdlib>
#include <filesystem>

namespace loopd::test {

std::string data_dir() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("LOOPD_DATA_DIR"); env && fs::is_directory(env)) return env;
  if (fs::is_directory(LOOPD_DEFAULT_DATA_DIR)) return LOOPD_DEFAULT_DATA_DIR;
  return "";
}

std::string data_file(const std::string& relative) {
  const std::string dir = data_dir();
  if (dir.empty()) return "";
  const std::string path = dir + "/" + relative;
  return std::filesystem::exists(path) ? path : "";
}

}  // namespace loopd::test
