#include "support/fault_log.hpp"

#include <functional>
#include <map>
#include <random>

#include <loopd/pose_t.hpp>

#include "lcm_log.hpp"
#include "loopd/base/pose.hpp"
#include "message_convert.hpp"

namespace loopd::test {
namespace {

// Every loopd message type starts with its 8-byte fingerprint, then `int64_t utime` (big-endian).
constexpr std::size_t kUtimeAt = 8;

bool read_utime(const LogEvent& ev, std::int64_t* utime) {
  if (ev.data.size() < kUtimeAt + 8) return false;
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < 8; ++i) v = (v << 8) | ev.data[kUtimeAt + i];
  *utime = static_cast<std::int64_t>(v);
  return true;
}

void write_utime(LogEvent* ev, std::int64_t utime) {
  const auto v = static_cast<std::uint64_t>(utime);
  for (std::size_t i = 0; i < 8; ++i) ev->data[kUtimeAt + i] = static_cast<std::uint8_t>(v >> (56 - 8 * i));
}

/// Emits one event into the faulty copy; false on a write error.
using Emit = std::function<bool(const LogEvent&)>;

/// Copies `in` to `out` event by event through `transform` (which emits zero or more events per input event).
FaultResult copy_through(const std::string& in, const std::string& out, const std::function<bool(LogEvent&, const Emit&, FaultResult*)>& transform) {
  FaultResult r;
  LogReader reader;
  LogWriter writer;
  if (!reader.open(in, &r.error)) return r;
  if (!writer.open(out, &r.error)) return r;
  const Emit emit = [&](const LogEvent& ev) {
    if (!writer.write(ev.channel, ev.timestamp, ev.data.data(), ev.data.size())) return false;
    ++r.events_out;
    return true;
  };
  LogEvent ev;
  while (reader.next(&ev)) {
    ++r.events_in;
    if (!transform(ev, emit, &r)) {
      if (r.error.empty()) r.error = out + ": write failed at event " + std::to_string(r.events_in);
      return r;
    }
  }
  writer.close();
  r.ok = true;
  return r;
}

std::vector<LogEvent> read_all(const std::string& path, std::string* error) {
  std::vector<LogEvent> events;
  LogReader reader;
  if (!reader.open(path, error)) return events;
  LogEvent ev;
  while (reader.next(&ev)) events.push_back(std::move(ev));
  return events;
}

/// Writes `events` to `out`; sets r->ok, or r->error.
void write_all(const std::vector<LogEvent>& events, const std::string& out, FaultResult* r) {
  LogWriter writer;
  if (!writer.open(out, &r->error)) return;
  for (const auto& ev : events) {
    if (!writer.write(ev.channel, ev.timestamp, ev.data.data(), ev.data.size())) {
      r->error = out + ": write failed at event " + std::to_string(r->events_out + 1);
      return;
    }
    ++r->events_out;
  }
  writer.close();
  r->ok = true;
}

}  // namespace

FaultResult drop_messages(const std::string& in, const std::string& out, const std::string& channel, double fraction, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  return copy_through(in, out, [&](LogEvent& ev, const Emit& emit, FaultResult* r) {
    if (ev.channel == channel && uniform(rng) < fraction) {
      ++r->affected;
      return true;
    }
    return emit(ev);
  });
}

FaultResult remove_window(const std::string& in, const std::string& out, const std::string& channel, std::int64_t from_utime, std::int64_t to_utime) {
  return copy_through(in, out, [&](LogEvent& ev, const Emit& emit, FaultResult* r) {
    std::int64_t u = 0;
    if (ev.channel == channel && read_utime(ev, &u) && u >= from_utime && u < to_utime) {
      ++r->affected;
      return true;
    }
    return emit(ev);
  });
}

FaultResult shift_clock(const std::string& in, const std::string& out, std::int64_t from_utime, std::int64_t shift_us) {
  return copy_through(in, out, [&](LogEvent& ev, const Emit& emit, FaultResult* r) {
    std::int64_t u = 0;
    if (read_utime(ev, &u) && u >= from_utime) {
      write_utime(&ev, u + shift_us);
      ++r->affected;
    }
    return emit(ev);
  });
}

FaultResult duplicate_messages(const std::string& in, const std::string& out, const std::vector<std::string>& channels) {
  return copy_through(in, out, [&](LogEvent& ev, const Emit& emit, FaultResult* r) {
    bool listed = false;
    for (const auto& c : channels) listed = listed || ev.channel == c;
    if (!emit(ev)) return false;
    if (!listed) return true;
    ++r->affected;
    return emit(ev);
  });
}

FaultResult swap_neighbours(const std::string& in, const std::string& out, const std::string& channel, double fraction, std::int64_t max_apart_us,
                            std::uint64_t seed) {
  FaultResult r;
  std::vector<LogEvent> events = read_all(in, &r.error);
  if (!r.error.empty()) return r;
  r.events_in = static_cast<std::int64_t>(events.size());
  std::vector<std::size_t> on_channel;
  for (std::size_t i = 0; i < events.size(); ++i)
    if (events[i].channel == channel) on_channel.push_back(i);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (std::size_t k = 0; k + 1 < on_channel.size(); ++k) {
    LogEvent& a = events[on_channel[k]];
    LogEvent& b = events[on_channel[k + 1]];
    std::int64_t ua = 0, ub = 0;
    if (uniform(rng) >= fraction || !read_utime(a, &ua) || !read_utime(b, &ub) || ub - ua > max_apart_us) continue;
    // The payloads trade places; each position keeps its logger timestamp (the logger stamps on arrival).
    std::swap(a.data, b.data);
    ++r.affected;
    ++k;  // pairs do not overlap: the newer message arrives exactly one place early
  }
  write_all(events, out, &r);
  return r;
}

FaultResult deliver_before(const std::string& in, const std::string& out, const std::string& channel, const std::string& ahead_of) {
  FaultResult r;
  std::vector<LogEvent> events = read_all(in, &r.error);
  if (!r.error.empty()) return r;
  r.events_in = static_cast<std::int64_t>(events.size());
  for (std::size_t i = 0; i < events.size(); ++i) {
    std::int64_t u = 0, v = 0;
    if (events[i].channel != channel || !read_utime(events[i], &u)) continue;
    std::size_t j = i;
    bool found = false;
    while (!found && j > 0 && events[j - 1].channel != channel) {
      --j;
      found = events[j].channel == ahead_of && read_utime(events[j], &v) && v == u;
    }
    if (!found) continue;
    // Move event i to position j; the payloads and channels shift, the timestamps stay where they were.
    for (std::size_t k = i; k > j; --k) {
      std::swap(events[k].channel, events[k - 1].channel);
      std::swap(events[k].data, events[k - 1].data);
    }
    ++r.affected;
  }
  write_all(events, out, &r);
  return r;
}

FaultResult splice_channel(const std::string& in, const std::string& other, const std::string& out, const std::string& channel,
                           std::int64_t from_utime) {
  FaultResult r;
  std::map<std::int64_t, std::vector<std::uint8_t>> replacement;
  {
    LogReader reader;
    if (!reader.open(other, &r.error)) return r;
    LogEvent ev;
    std::int64_t u = 0;
    while (reader.next(&ev))
      if (ev.channel == channel && read_utime(ev, &u) && u >= from_utime) replacement[u] = std::move(ev.data);
  }
  FaultResult copied = copy_through(in, out, [&](LogEvent& ev, const Emit& emit, FaultResult* res) {
    std::int64_t u = 0;
    if (ev.channel != channel || !read_utime(ev, &u) || u < from_utime) return emit(ev);
    auto it = replacement.find(u);
    if (it == replacement.end()) return true;  // no counterpart: the message is left out
    ev.data = std::move(it->second);
    ++res->affected;
    return emit(ev);
  });
  return copied;
}

FaultResult reset_odometry(const std::string& in, const std::string& out, const std::string& channel, std::int64_t from_utime) {
  bool started = false;
  Eigen::Isometry3d T_reset_inv = Eigen::Isometry3d::Identity();
  std::int64_t seq = 0;
  return copy_through(in, out, [&](LogEvent& ev, const Emit& emit, FaultResult* r) {
    std::int64_t u = 0;
    if (ev.channel != channel || !read_utime(ev, &u) || u < from_utime) return emit(ev);
    pose_t msg;
    StampedPose pose;
    std::string why;
    if (!LogReader::decode(ev, &msg) || !from_message(msg, &pose, &why)) {
      r->error = "pose at utime " + std::to_string(u) + " does not decode: " + why;
      return false;
    }
    if (!started) {
      T_reset_inv = pose.T_world_sensor.inverse();
      started = true;
    }
    pose.T_world_sensor = T_reset_inv * pose.T_world_sensor;
    pose_t reset = to_message(pose, seq++);
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(reset.getEncodedSize()));
    if (reset.encode(buf.data(), 0, static_cast<int>(buf.size())) < 0) {
      r->error = "pose at utime " + std::to_string(u) + " does not encode";
      return false;
    }
    ev.data = std::move(buf);
    ++r->affected;
    return emit(ev);
  });
}

std::vector<std::int64_t> channel_utimes(const std::string& path, const std::string& channel) {
  std::vector<std::int64_t> utimes;
  LogReader reader;
  std::string error;
  if (!reader.open(path, &error)) return utimes;
  LogEvent ev;
  std::int64_t u = 0;
  while (reader.next(&ev))
    if (ev.channel == channel && read_utime(ev, &u)) utimes.push_back(u);
  return utimes;
}

}  // namespace loopd::test
