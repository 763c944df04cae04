#include "support/hostile_log.hpp"

#include <cstdio>
#include <random>

#include <loopd/point_cloud_t.hpp>

#include "lcm_log.hpp"

namespace loopd::test {
namespace {
void put_int32(std::vector<std::uint8_t>* buf, std::size_t at, std::int32_t v) {
  const auto u = static_cast<std::uint32_t>(v);
  for (int i = 0; i < 4; ++i) (*buf)[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(u >> (24 - 8 * i));
}
}  // namespace

std::vector<std::vector<std::uint8_t>> crafted_scan_payloads() {
  point_cloud_t m{};
  m.utime = 123;
  m.frame = "lidar";
  m.num_points = 0;
  std::vector<std::uint8_t> valid(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(valid.data(), 0, static_cast<int>(valid.size()));
  const std::size_t num_points_at = 8 + 8 + 8 + 4 + m.frame.size() + 1;

  std::vector<std::uint8_t> random_after_fingerprint(valid.begin(), valid.begin() + 8);
  std::mt19937 rng(2026);
  for (int i = 0; i < 4000; ++i) random_after_fingerprint.push_back(static_cast<std::uint8_t>(rng()));
  // Make the frame length sane so the random part reaches the arrays (the harder case for a decoder).
  put_int32(&random_after_fingerprint, 24, 6);
  random_after_fingerprint[28 + 5] = 0;
  for (int i = 0; i < 5; ++i) random_after_fingerprint[28 + static_cast<std::size_t>(i)] = 'a';

  std::vector<std::uint8_t> minus_one = valid;
  minus_one.resize(60, 0);
  put_int32(&minus_one, num_points_at, -1);
  std::vector<std::uint8_t> huge = minus_one;
  put_int32(&huge, num_points_at, 2147483647);
  return {random_after_fingerprint, minus_one, huge};
}

int copy_with_crafted_scans(const std::string& in, const std::string& out, const std::string& scan_channel, int after_event, bool damage_header) {
  LogReader reader;
  LogWriter writer;
  std::string error;
  if (!reader.open(in, &error) || !writer.open(out, &error)) return -1;
  LogEvent ev;
  int index = 0, inserted = 0;
  const auto crafted = crafted_scan_payloads();
  while (reader.next(&ev)) {
    if (!writer.write(ev.channel, ev.timestamp, ev.data.data(), ev.data.size())) return -1;
    ++index;
    if (index == after_event) {
      for (const auto& payload : crafted) writer.write(scan_channel, ev.timestamp, payload.data(), payload.size());
      inserted += static_cast<int>(crafted.size());
    }
    if (damage_header && index == 2 * after_event) {
      // A damaged event: a sync word and a header whose data length says 2^31 - 1, then a few bytes; the next
      // event follows intact. The reader must skip it and resynchronise.
      const unsigned char bad[] = {0xED, 0xA1, 0xDA, 0x01, 0, 0, 0,    0,    0,    0,    0,   1,   0,   0,   0, 0, 0, 0,
                                   0,    2,    0,    0,    0, 4, 0x7F, 0xFF, 0xFF, 0xFF, 'J', 'U', 'N', 'K', 1, 2, 3};
      if (!writer.append_bytes(bad, sizeof(bad))) return -1;
    }
  }
  return inserted;
}

}  // namespace loopd::test
