#pragma once
/// @file A gyro riding with the lidar (in the lidar's frame): the true turn rate of a drive plus white noise and a
/// constant bias per axis, sampled on a fixed grid.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/imu.hpp"
#include "loopd/sim/drive.hpp"

namespace loopd {

/// @brief Settings of simulate_gyro. The defaults are a good MEMS gyro (Xsens MTi-class: noise density ~0.007 deg/s
///        per sqrt(Hz), in-run bias ~10 deg/h; its datasheet): at 200 Hz that is 0.1 deg/s per sample.
struct GyroSimConfig {
  double rate_hz = 200.0;    ///< samples per second (0: no gyro)
  double noise_deg_s = 0.1;  ///< [deg/s] white noise per sample and axis
  double bias_deg_s = 0.05;  ///< [deg/s] each axis' constant bias is drawn uniformly from +-this (seeded by the drive)
  std::optional<std::string> validate() const;
};

/// @brief The gyro samples of scan i's sweep: every grid time (start_utime + k / rate_hz) in (utime of scan i - 1,
///        utime of scan i] (scan 0: the sweep's length before its stamp). The rate at time t is the mean turn rate over
///        the sample period before it, [t - h, t], of the drive's true path (what an integrating gyro reports: the
///        simulator's heading steps every 5 cm of route, which no instantaneous rate samples), in the sensor frame; then
///        the bias and the noise (seeded by the drive's seed, session and sample index).
std::vector<ImuSample> simulate_gyro(const Drive& drive, const GyroSimConfig& config, int scan_index);

}  // namespace loopd
