#include "support/run_command.hpp"

#include <catch2/catch.hpp>
#include <cstdio>
#include <sys/wait.h>

namespace loopd::test {

std::string run_command(const std::string& command, int* exit_code) {
  std::string out;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  char buf[4096];
  while (p && fgets(buf, sizeof(buf), p)) out += buf;
  const int status = p ? pclose(p) : -1;
  *exit_code = (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
  return out;
}

std::string run_ok(const std::string& command) {
  int rc = 0;
  const std::string out = run_command(command, &rc);
  INFO(command << "\n" << out);
  REQUIRE(rc == 0);
  return out;
}

std::string last_line(const std::string& text) {
  std::string t = text;
  while (!t.empty() && t.back() == '\n') t.pop_back();
  const auto nl = t.rfind('\n');
  return nl == std::string::npos ? t : t.substr(nl + 1);
}

}  // namespace loopd::test
