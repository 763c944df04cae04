// loopd-bench register: placeholder until its stage lands; exits with an error instead of printing figures.
#include <iostream>

int run_bench_register(int /*argc*/, char** /*argv*/) {
  std::cerr << "loopd-bench register: not built yet\n";
  return 2;
}
