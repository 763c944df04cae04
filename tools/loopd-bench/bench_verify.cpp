// loopd-bench verify: placeholder until its stage lands; exits with an error instead of printing figures.
#include <iostream>

int run_bench_verify(int /*argc*/, char** /*argv*/) {
  std::cerr << "loopd-bench verify: not built yet\n";
  return 2;
}
