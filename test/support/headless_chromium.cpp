#include "support/headless_chromium.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <unistd.h>

#include "support/process.hpp"

namespace loopd::test {
namespace {

/// chromium --headless with a profile of its own (removed after), SwiftShader's WebGL, no sandbox (tests run as root).
std::string chromium_command(const std::string& what, int budget_ms, int width, int height) {
  static int runs = 0;
  const std::string profile =
      (std::filesystem::temp_directory_path() / ("loopd_chromium_" + std::to_string(getpid()) + "_" + std::to_string(runs++))).string();
  return "timeout 120 chromium --headless --no-sandbox --no-first-run --disable-extensions --enable-unsafe-swiftshader "
         "--use-angle=swiftshader --user-data-dir=" +
         profile + " --window-size=" + std::to_string(width) + "," + std::to_string(height) +
         " --hide-scrollbars --virtual-time-budget=" + std::to_string(budget_ms) + " " + what + " 2>/dev/null; rm -rf " + profile;
}

}  // namespace

bool chromium_available() { return run_quiet("command -v chromium") == 0; }

std::string chromium_dom(const std::string& url, int budget_ms) {
  FILE* pipe = popen(chromium_command("--dump-dom '" + url + "'", budget_ms, 1500, 1100).c_str(), "r");
  if (!pipe) return "";
  std::string dom;
  std::array<char, 65536> buffer;
  for (std::size_t n; (n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0;) dom.append(buffer.data(), n);
  pclose(pipe);
  return dom;
}

bool chromium_screenshot(const std::string& url, const std::string& png, int width, int height, int budget_ms) {
  std::filesystem::remove(png);
  run_quiet(chromium_command("--screenshot='" + png + "' '" + url + "'", budget_ms, width, height));
  return std::filesystem::exists(png) && std::filesystem::file_size(png) > 0;
}

std::string element_text(const std::string& dom, const std::string& id) {
  std::smatch m;
  if (!std::regex_search(dom, m, std::regex("id=\"" + id + "\"[^>]*>([^<]*)<"))) return "";
  std::string text = m[1].str();
  text.erase(std::remove(text.begin(), text.end(), ','), text.end());
  return text;
}

std::string body_attribute(const std::string& dom, const std::string& name) {
  std::smatch body;
  if (!std::regex_search(dom, body, std::regex("<body[^>]*>"))) return "";
  std::smatch m;
  const std::string tag = body[0].str();
  return std::regex_search(tag, m, std::regex(" " + name + "=\"([^\"]*)\"")) ? m[1].str() : "";
}

}  // namespace loopd::test
