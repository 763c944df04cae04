#pragma once
// A simulated drive replayed through a LoopdEngine as `loopd --replay` does (nothing shed, CPU descriptors), for the
// engine-level tests.
#include <catch2/catch.hpp>

#include <string>

#include "loopd/runtime/loopd_engine.hpp"
#include "loopd/sim/drive.hpp"

namespace loopd::test {

inline EngineConfig replay_config(const std::string& sensor = "vlp16") {
  EngineConfig c;
  c.detector.sensor = sensor;
  c.num_threads = 2;
  c.block_when_full = true;  // replay: nothing is shed
  c.detector.m2dp.backend = Backend::kCpu;
  return c;
}

/// @brief Every scan and pose of `drive` at its own time, then finish().
inline void replay_drive(LoopdEngine& engine, const Drive& drive) {
  for (const DriveScan& s : drive.scans) {
    const double arrival = static_cast<double>(s.utime) * 1e-6;
    engine.push_pose(s.odometry, arrival);
    REQUIRE(engine.push_scan(s.utime, drive.simulate(s.index, 2), arrival));
  }
  engine.finish();
}

}  // namespace loopd::test
