#include "loopd/runtime/map_writer.hpp"

#include <chrono>
#include <optional>
#include <cstdio>
#include <thread>

#include "loopd/runtime/map_records_convert.hpp"

namespace loopd {

template <typename Write>
StoreStatus MapWriter::retry_busy(Write&& write) {
  StoreStatus s = write();
  for (int attempt = 0; s.code == StoreStatus::Code::kBusy && attempt < 2; ++attempt) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100 << (2 * attempt)));  // 0.1, 0.4 s; then the buffer's backoff
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.busy_retries;
    }
    s = write();
  }
  return s;
}

namespace {
bool transient(const StoreStatus& s) { return s.code == StoreStatus::Code::kBusy || s.code == StoreStatus::Code::kUnavailable; }
}  // namespace

void MapWriter::give_up(const std::string& what, const StoreStatus& status) {
  std::int64_t keyframes = 0, others = 0;
  for (const Pending& p : pending_) (p.keyframe ? keyframes : others) += 1;
  if (!pending_.empty() && pending_.front().what == what) (pending_.front().keyframe ? keyframes : others) -= 1;  // `what` itself
  pending_.clear();
  buffered_keyframes_ = 0;
  stopped_ = true;
  const std::string lost = keyframes + others == 0 ? std::string()
                                                   : "; lost with it: " + std::to_string(keyframes) + " buffered keyframes and " +
                                                         std::to_string(others) + " other buffered writes";
  std::int64_t n = 0;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    n = (stats_.failures += 1 + keyframes + others);
    stats_.buffered = 0;
    stats_.last_error = what + ": " + status.message + lost;
  }
  std::fprintf(stderr,
               "loopd: MAP WRITE GIVEN UP: %s: %s%s; nothing more is written to the map until restart (it stays a consistent prefix "
               "that a restart resumes from); detection goes on in memory, %lld writes not in the map so far\n",
               what.c_str(), status.message.c_str(), lost.c_str(), static_cast<long long>(n));
}

void MapWriter::failed(const std::string& what, const StoreStatus& status) {
  std::int64_t n = 0;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    n = ++stats_.failures;
  }
  if ((n - 1) % log_every_n_ == 0)
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
  decided_with_correction_.reset();
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
  write("loop event " + std::to_string(decision.event_id), [this, decision] {
    StoreStatus s = store_.put_loop(decision);
    if (s.ok()) {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.decisions_written;
    }
    return s;
  });
  next_.on_decision(decision);
  // Published: a restart that decides it again does not publish it again (RepublishFilter).
  const std::int64_t event_id = decision.event_id;
  write("loop event " + std::to_string(event_id) + " published", [this, event_id] { return store_.mark_published(event_id); });
}

void MapWriter::on_correction(const CorrectionOutput& correction) {
  store_correction(correction);
  next_.on_correction(correction);
}

void MapWriter::on_final_correction(const CorrectionOutput& correction) {
  // The run's last word: the map keeps it (loopd-map trajectory is what was published last, and a restart resumes
  // from it at the newest keyframe), then it is published.
  store_correction(correction);
  next_.on_final_correction(correction);
}

void MapWriter::store_correction(const CorrectionOutput& correction) {
  if (correction_delay_ms_ > 0) std::this_thread::sleep_for(std::chrono::milliseconds(correction_delay_ms_));
  // The correction and "its keyframe is decided" in one transaction: a stop between them would leave a correction
  // naming a keyframe that resume removes.
  std::optional<KeyframeKey> decided;
  if (!correction.keys.empty()) decided = correction.keys.back();
  decided_with_correction_ = decided;
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
}

void MapWriter::on_keyframe_decided(const KeyframeKey& keyframe) {
  if (!(decided_with_correction_ && *decided_with_correction_ == keyframe))
    write("keyframe " + to_string(keyframe) + " decided", [this, keyframe] { return store_.mark_decided(keyframe); });
  decided_with_correction_.reset();
  next_.on_keyframe_decided(keyframe);
}

void MapWriter::on_keyframes_retired(const KeyframeKey& by, const std::vector<KeyframeKey>& retired) {
  // One transaction; the keyframes were decided (and so written) before `by`, so an order-keeping buffer has them first.
  write(std::to_string(retired.size()) + " keyframes retired by keyframe " + to_string(by), [this, retired] {
    if (StoreStatus s = store_.retire_keyframes(retired); !s.ok()) return s;
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.keyframes_retired += static_cast<std::int64_t>(retired.size());
    return StoreStatus{};
  });
  next_.on_keyframes_retired(by, retired);
}

void MapWriter::write(std::string what, std::function<StoreStatus()> transaction, bool keyframe) {
  if (stopped_) return failed(what, stopped_status());
  if (!pending_.empty() && retry_due()) flush_pending(false);
  if (stopped_) return failed(what, stopped_status());
  if (pending_.empty()) {
    const StoreStatus s = retry_busy(transaction);
    if (s.ok()) return;
    if (!transient(s)) return give_up(what, s);
    waiting(s);
  }
  if (keyframe && ++buffered_keyframes_ > max_buffered_keyframes_) {
    StoreStatus full;
    full.code = StoreStatus::Code::kIo;
    full.message = "more than " + std::to_string(max_buffered_keyframes_) + " keyframes wait for the map (map.max_buffered_keyframes)";
    return give_up(what, full);
  }
  pending_.push_back({std::move(what), std::move(transaction), keyframe});
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.buffered = static_cast<std::int64_t>(pending_.size());
}

void MapWriter::waiting(const StoreStatus& status) {
  if (!buffering_) {
    const char* why = status.code == StoreStatus::Code::kBusy ? "map busy (another process holds its lock)" : "map server unavailable";
    std::fprintf(stderr, "loopd: %s: %s; buffering the map's writes in memory, tried again every <= %.1f s\n", why, status.message.c_str(),
                 static_cast<double>(retry_period_.count()) * 1e-3);
    backoff_ = std::chrono::milliseconds(250);
    next_retry_ = std::chrono::steady_clock::now() + backoff_;
  }
  buffering_ = true;
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.last_error = status.message;
}

void MapWriter::on_idle() {
  if (!pending_.empty() && !stopped_ && retry_due()) flush_pending(false);
  next_.on_idle();
}

bool MapWriter::flush_pending(bool wait) {
  // The store reconnects at most once a second: without `wait`, one try per call, the next after the backoff.
  while (!pending_.empty() && !stopped_) {
    Pending& next = pending_.front();
    const StoreStatus s = retry_busy(next.transaction);
    if (transient(s)) {
      {
        std::lock_guard<std::mutex> lock(stats_mutex_);
        ++stats_.retries;
        stats_.last_error = s.message;
      }
      backoff_ = std::min(retry_period_, backoff_ * 2);
      next_retry_ = std::chrono::steady_clock::now() + backoff_;
      if (!wait) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
      if (std::chrono::steady_clock::now() >= flush_deadline_) return false;
      continue;
    }
    if (!s.ok()) {
      give_up(next.what, s);
      break;
    }
    if (next.keyframe) --buffered_keyframes_;
    pending_.pop_front();
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.flushed;
  }
  if (pending_.empty() && buffering_) {
    buffering_ = false;
    backoff_ = std::chrono::milliseconds(250);
    if (!stopped_) {
      std::fprintf(stderr, "loopd: map back: every buffered write is stored\n");
      std::lock_guard<std::mutex> lock(stats_mutex_);
      stats_.last_error.clear();
    }
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
