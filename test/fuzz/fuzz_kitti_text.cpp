// KITTI text files read by kitti2lcm and loopd-eval: poses (12 numbers a line), times.txt and calib.txt ("Tr:").
// Each reader takes a path, so the input goes through a temp file.
#include "fuzz_support.hpp"
#include "loopd/core/trajectory_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  static fuzz::TempFile file(".txt");
  const std::string& path = file.write(data, size);
  std::string error;
  std::vector<Eigen::Isometry3d> poses;
  if (read_kitti_poses(path, &poses, &error)) {
    fuzz::check(!poses.empty(), "poses were read");
    for (const auto& T : poses) fuzz::check(T.matrix().allFinite(), "poses are finite");
  } else {
    fuzz::check_error_names(error, path);
  }
  std::vector<double> times;
  error.clear();
  if (read_kitti_times(path, &times, &error)) {
    for (std::size_t i = 0; i < times.size(); ++i) {
      fuzz::check(std::abs(times[i]) <= 1e11, "times are bounded");
      fuzz::check(i == 0 || times[i] >= times[i - 1], "times do not go backwards");
    }
  } else {
    fuzz::check_error_names(error, path);
  }
  Eigen::Isometry3d Tr;
  error.clear();
  if (read_kitti_calib_tr(path, &Tr, &error)) {
    fuzz::check(Tr.matrix().allFinite(), "calibration is finite");
  } else {
    fuzz::check_error_names(error, path);
  }
  return 0;
}
