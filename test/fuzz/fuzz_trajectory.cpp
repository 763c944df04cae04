// Trajectory text (KITTI 3x4 and TUM): any text parses or fails with "<source>:<line>: <reason>"; parsed poses are
// finite rigid transforms.
#include <sstream>

#include "fuzz_support.hpp"
#include "loopd/base/trajectory_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  const std::string text = fuzz::as_string(data, size);
  for (TrajectoryFormat format : {TrajectoryFormat::kKitti, TrajectoryFormat::kTum}) {
    std::istringstream in(text);
    const TrajectoryFile f = parse_trajectory(in, format, "fuzz.txt");
    fuzz::check(f.ok == f.error.empty(), "ok exactly when there is no error");
    if (!f.ok) {
      fuzz::check_error_names(f.error, "fuzz.txt");
      continue;
    }
    fuzz::check(!f.poses.empty() && f.poses.size() == f.stamps.size(), "one stamp per pose");
    for (const auto& T : f.poses) {
      fuzz::check(T.matrix().allFinite(), "poses are finite");
      fuzz::check(std::abs(T.linear().determinant() - 1.0) < 1e-6, "rotations are rotations");
    }
  }
  return 0;
}
