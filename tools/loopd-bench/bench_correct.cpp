// loopd-bench correct: placeholder until its stage lands; exits with an error instead of printing figures.
#include <iostream>

int run_bench_correct(int /*argc*/, char** /*argv*/) {
  std::cerr << "loopd-bench correct: not built yet\n";
  return 2;
}
