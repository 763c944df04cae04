// loopd-bench pipeline: placeholder until its stage lands; exits with an error instead of printing figures.
#include <iostream>

int run_bench_pipeline(int /*argc*/, char** /*argv*/) {
  std::cerr << "loopd-bench pipeline: not built yet\n";
  return 2;
}
