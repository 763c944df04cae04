#pragma once
// The small drive the library-level tests share: a simulated VLP-16 block lap and its revisit (340 scans, seed 23;
// more scans drive more revisits), instantaneous scans (no motion skew), so every keyframe step is measured by the scans.
#include <catch2/catch.hpp>

#include "loopd/sim/drive.hpp"

namespace loopd::test {

inline Drive block_revisit_drive(int num_scans = 340) {
  DriveConfig dc;
  dc.sensor = "vlp16";
  dc.route = "block";
  dc.num_scans = num_scans;
  dc.seed = 23;
  dc.effects.motion_skew = false;
  Drive drive = make_drive(dc);
  REQUIRE(drive.error.empty());
  return drive;
}

}  // namespace loopd::test
