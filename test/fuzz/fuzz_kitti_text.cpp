// KITTI text files read by kitti2lcm and loopd-eval: poses (read_trajectory kKitti, 12 numbers a line), times.txt
// and calib.txt ("Tr:"). Each reader takes a path, so the input goes through a temp file.
#include "fuzz_support.hpp"
#include "loopd/base/trajectory_io.hpp"
#include "loopd/io/kitti_files.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  static fuzz::TempFile file(".txt");
  const std::string& path = file.write(data, size);
  const TrajectoryFile poses = read_trajectory(path, TrajectoryFormat::kKitti);
  fuzz::check(poses.ok == poses.error.empty(), "ok exactly when there is no error");
  if (poses.ok) {
    fuzz::check(!poses.poses.empty(), "poses were read");
    for (const auto& T : poses.poses) fuzz::check(T.matrix().allFinite(), "poses are finite");
  } else {
    fuzz::check_error_names(poses.error, path);
  }
  const KittiTimes times = read_kitti_times(path);
  fuzz::check(times.ok == times.error.empty(), "ok exactly when there is no error");
  if (times.ok) {
    for (std::size_t i = 0; i < times.seconds.size(); ++i) {
      fuzz::check(std::abs(times.seconds[i]) <= 1e11, "times are bounded");
      fuzz::check(i == 0 || times.seconds[i] >= times.seconds[i - 1], "times do not go backwards");
    }
  } else {
    fuzz::check_error_names(times.error, path);
  }
  const KittiCalibration calib = read_kitti_calib_tr(path);
  fuzz::check(calib.ok == calib.error.empty(), "ok exactly when there is no error");
  if (calib.ok) {
    fuzz::check(calib.T_cam_velo.matrix().allFinite(), "calibration is finite");
  } else {
    fuzz::check_error_names(calib.error, path);
  }
  return 0;
}
