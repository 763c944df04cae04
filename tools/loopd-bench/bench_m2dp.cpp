// loopd-bench m2dp: placeholder until its stage lands; exits with an error instead of printing figures.
#include <iostream>

int run_bench_m2dp(int /*argc*/, char** /*argv*/) {
  std::cerr << "loopd-bench m2dp: not built yet\n";
  return 2;
}
