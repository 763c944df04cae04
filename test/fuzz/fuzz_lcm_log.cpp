// The LCM log-file path of loopd --replay and the tools: LogReader over a damaged lcm-logger file, each event decoded
// with decode_bounded as every known message type (an event must be rejected or round-trip).
#include "decode_round_trip.hpp"
#include "lcm_log.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  static fuzz::TempFile file(".lcmlog");
  const std::string& path = file.write(data, size);
  LogReader reader;
  std::string error;
  if (!reader.open(path, &error)) return 0;
  LogEvent event;
  int events = 0;
  while (reader.next(&event) && events++ < 1000) {
    fuzz::check(event.data.size() <= size, "an event holds no more bytes than the file");
    const std::uint8_t* p = event.data.data();
    const std::size_t n = event.data.size();
    fuzz::decode_any_point_cloud_round_trip(p, n);
    fuzz::decode_round_trip<pose_t>(p, n);
    fuzz::decode_round_trip<imu_t>(p, n);
    fuzz::decode_round_trip<loop_event_t>(p, n);
    fuzz::decode_round_trip<trajectory_t>(p, n);
    fuzz::decode_round_trip<status_t>(p, n);
  }
  return 0;
}
