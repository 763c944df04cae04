#include "map_writer.hpp"

#include <chrono>
#include <optional>
#include <cstdio>
#include <thread>

#include "map_records_convert.hpp"

namespace loopd {

template <typename Write>
StoreStatus MapWriter::retry_busy(Write&& write) {
  StoreStatus s = write();
  for (int attempt = 0; s.code == StoreStatus::Code::kBusy && attempt < 3; ++attempt) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100 << (2 * attempt)));  // 0.1, 0.4, 1.6 s
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.busy_retries;
    }
    s = write();
  }
  return s;
}

void MapWriter::failed(const std::string& what, const StoreStatus& status) {
  const bool first = !stopped_;
  stopped_ = true;
  std::int64_t n = 0;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    n = ++stats_.failures;
    if (first) stats_.last_error = what + ": " + status.message;  // the write that stopped the map, and why
  }
  if (n == 1 || (n - 1) % log_every_n_ == 0)
    std::fprintf(stderr, "loopd: MAP WRITE FAILED (%lld so far): %s: %s; detection goes on in memory, what is not on disk is lost at exit\n",
                 static_cast<long long>(n), what.c_str(), status.message.c_str());
}

StoreStatus MapWriter::ensure_session(SessionId session, std::int64_t first_utime) {
  if (!sessions_) {
    StoreResult<std::vector<SessionRecord>> read = store_.sessions();
    if (!read.ok()) return read.status;
    sessions_.emplace();
    for (SessionRecord& r : read.value) (*sessions_)[r.id] = std::move(r);
  }
  const auto it = sessions_->find(session);
  if (it != sessions_->end() && it->second.first_utime != 0) return {};
  SessionRecord r;
  if (it != sessions_->end()) {
    r = it->second;
  } else {
    r.id = session;
    r.sensor = sensor_;
    r.source = source_;
    r.anchored = sessions_->empty();  // the map's first session is the map frame; the others wait for a loop
  }
  r.first_utime = first_utime;
  const StoreStatus s = store_.put_session(r);
  if (s.ok()) (*sessions_)[session] = r;
  return s;
}

StoreStatus MapWriter::put_alignments(const std::vector<SessionAlignment>& alignments) {
  if (!sessions_) return {};
  for (const SessionAlignment& a : alignments) {
    const auto it = sessions_->find(a.session);
    if (it == sessions_->end()) continue;
    SessionRecord r = it->second;
    r.anchored = a.anchored;
    r.T_map_session = a.T_map_session;
    if (r.anchored == it->second.anchored && r.T_map_session.isApprox(it->second.T_map_session, 1e-12)) continue;
    if (StoreStatus s = store_.put_session(r); !s.ok()) return s;
    it->second = r;
  }
  return {};
}

void MapWriter::on_keyframe(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_sensor, const MapCloudBlob& map_cloud) {
  decided_with_correction_ = false;
  const std::int64_t cloud_bytes = map_cloud ? static_cast<std::int64_t>(map_cloud->size()) : 0;
  write(
      "keyframe " + to_string(keyframe.key),
      [this, record = MapKeyframe{keyframe, T_map_sensor, map_cloud}, cloud_bytes] {
        if (StoreStatus s = ensure_session(record.record.key.session, record.record.utime); !s.ok()) return s;
        StoreStatus s = store_.put_keyframe(record);
        if (s.ok()) {
          std::lock_guard<std::mutex> lock(stats_mutex_);
          ++stats_.keyframes_written;
          stats_.map_cloud_bytes += cloud_bytes;
        }
        return s;
      },
      true);
}

void MapWriter::on_decision(const LoopDecision& decision) {
  write("loop event " + std::to_string(decision.event_id), [this, record = to_loop_record(decision)] {
    StoreStatus s = store_.put_loop(record);
    if (s.ok()) {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.decisions_written;
    }
    return s;
  });
  next_.on_decision(decision);
}

void MapWriter::on_correction(const CorrectionOutput& correction) {
  if (correction_delay_ms_ > 0) std::this_thread::sleep_for(std::chrono::milliseconds(correction_delay_ms_));
  // The correction and "its keyframe is decided" in one transaction: a stop between them would leave a correction
  // naming a keyframe that resume removes.
  decided_with_correction_ = true;
  std::optional<KeyframeKey> decided;
  if (!correction.keys.empty()) decided = correction.keys.back();
  write("correction revision " + std::to_string(correction.revision),
        [this, record = to_correction_record(correction), alignments = correction.sessions, decided] {
          StoreStatus s = store_.begin();
          if (!s.ok()) return s;
          s = store_.put_correction(record);
          if (s.ok()) s = put_alignments(alignments);
          if (s.ok() && decided) s = store_.mark_decided(*decided);
          if (s.ok()) s = store_.commit();
          if (!s.ok()) store_.rollback();
          if (s.ok()) {
            std::lock_guard<std::mutex> lock(stats_mutex_);
            ++stats_.corrections_written;
          }
          return s;
        });
  next_.on_correction(correction);
}

void MapWriter::on_keyframe_decided(const KeyframeKey& keyframe) {
  if (!decided_with_correction_) write("keyframe " + to_string(keyframe) + " decided", [this, keyframe] { return store_.mark_decided(keyframe); });
  decided_with_correction_ = false;
  next_.on_keyframe_decided(keyframe);
}

void MapWriter::write(std::string what, std::function<StoreStatus()> transaction, bool keyframe) {
  if (stopped_) return failed(what, stopped_status());
  if (!pending_.empty()) flush_pending(false);
  if (pending_.empty()) {
    const StoreStatus s = retry_busy(transaction);
    if (s.ok()) return;
    if (s.code != StoreStatus::Code::kUnavailable) return failed(what, s);
    unavailable(s);
  }
  if (keyframe && ++buffered_keyframes_ > max_buffered_keyframes_) {
    StoreStatus full;
    full.code = StoreStatus::Code::kIo;
    full.message = "more than " + std::to_string(max_buffered_keyframes_) + " keyframes wait for the map server (map.max_buffered_keyframes)";
    pending_.clear();
    return failed(what, full);
  }
  pending_.push_back({std::move(what), std::move(transaction), keyframe});
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.buffered = static_cast<std::int64_t>(pending_.size());
}

void MapWriter::unavailable(const StoreStatus& status) {
  if (!buffering_)
    std::fprintf(stderr, "loopd: map server unavailable: %s; buffering the map's writes in memory until it is back\n", status.message.c_str());
  buffering_ = true;
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.last_error = status.message;
}

bool MapWriter::flush_pending(bool wait) {
  // The store reconnects at most once a second: without `wait`, one try per call.
  while (!pending_.empty() && !stopped_) {
    Pending& next = pending_.front();
    const StoreStatus s = retry_busy(next.transaction);
    if (s.code == StoreStatus::Code::kUnavailable) {
      if (!wait) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
      if (std::chrono::steady_clock::now() >= flush_deadline_) return false;
      continue;
    }
    if (!s.ok()) {
      failed(next.what, s);
      pending_.clear();
      break;
    }
    if (next.keyframe) --buffered_keyframes_;
    pending_.pop_front();
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.flushed;
  }
  if (pending_.empty() && buffering_) {
    std::fprintf(stderr, "loopd: map server back: every buffered write is stored\n");
    buffering_ = false;
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.buffered = static_cast<std::int64_t>(pending_.size());
  return pending_.empty();
}

bool MapWriter::flush(double timeout_s) {
  flush_deadline_ = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<std::int64_t>(timeout_s * 1000.0));
  return flush_pending(true);
}

StoreStatus MapWriter::stopped_status() {
  StoreStatus s;
  s.code = StoreStatus::Code::kIo;
  s.message = "not written: map writes stopped after an earlier refused write (restart to resume from the map)";
  return s;
}

MapWriterStats MapWriter::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

}  // namespace loopd
