// loopd: placeholder entry point until the daemon app lands (issue #2/#8).
#include <CLI/CLI.hpp>
#include <iostream>

int main(int argc, char** argv) {
  CLI::App app{"loopd: lidar loop-closure daemon"};
  app.set_version_flag("--version", std::string("loopd ") + LOOPD_VERSION);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
