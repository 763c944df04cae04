#pragma once
/// @file Odometry poses between two scans (an odometry published faster than the lidar turns: wheel or IMU-aided).
#include <vector>

#include "loopd/base/pose.hpp"
#include "loopd/sim/drive.hpp"

namespace loopd {

/// @brief The odometry's poses at every grid time (start_utime + k / rate_hz) strictly between scans i - 1 and i: the
///        odometry's pose at scan i - 1 moved along the true path from there, with the drift of the step to scan i
///        (its error against the true step) spread evenly over the step (a constant drift rate), so that the poses at
///        the scans stay those of Drive::scans. Empty for scan 0 and when rate_hz is not above the scan rate.
std::vector<StampedPose> odometry_between_scans(const Drive& drive, int scan_index, double rate_hz);

}  // namespace loopd
