// The daemon's YAML config: any text loads or fails with an error (never an exception); an accepted config dumps
// (--print-config) to YAML that loads back to the same dump.
#include "loopd/runtime/daemon_config.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  DaemonConfig config;
  std::string error;
  if (!load_config_text(fuzz::as_string(data, size), &config, &error)) {
    fuzz::check(!error.empty(), "a rejected config says why");
    return 0;
  }
  const std::string dumped = dump_config(config);
  DaemonConfig again;
  fuzz::check(load_config_text(dumped, &again, &error), "the dumped config loads back");
  fuzz::check(dump_config(again) == dumped, "the dumped config loads back to the same values");
  return 0;
}
