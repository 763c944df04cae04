// Loop and residual text files of loopd-correct: parse or fail with "<source>:<line>: <reason>".
#include <sstream>

#include "fuzz_support.hpp"
#include "loopd/correction/loop_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  const std::string text = fuzz::as_string(data, size);
  for (int num_poses : {-1, 50}) {
    std::istringstream in(text);
    const LoopFile f = parse_loops(in, "loops.txt", num_poses);
    fuzz::check(f.ok == f.error.empty(), "ok exactly when there is no error");
    if (!f.ok) {
      fuzz::check_error_names(f.error, "loops.txt");
      continue;
    }
    for (const auto& l : f.loops) {
      fuzz::check(l.query_index >= 0 && l.match_index >= 0, "indices are non-negative");
      fuzz::check(num_poses < 0 || (l.query_index < num_poses && l.match_index < num_poses), "indices are in range");
      fuzz::check(l.T_match_query.matrix().allFinite(), "transforms are finite");
    }
  }
  std::istringstream in(text);
  const ResidualFile r = parse_residuals(in, "residuals.txt");
  fuzz::check(r.ok == r.error.empty(), "ok exactly when there is no error");
  if (!r.ok) fuzz::check_error_names(r.error, "residuals.txt");
  for (double v : r.residuals) fuzz::check(std::isfinite(v) && v >= 0.0, "residuals are finite and >= 0");
  return 0;
}
