// loopd-bench gicp: placeholder until its stage lands; exits with an error instead of printing figures.
#include <iostream>

int run_bench_gicp(int /*argc*/, char** /*argv*/) {
  std::cerr << "loopd-bench gicp: not built yet\n";
  return 2;
}
