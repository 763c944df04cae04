#include "map_writer.hpp"

#include <chrono>
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
  if (stopped_) return failed("keyframe " + to_string(keyframe.key), stopped_status());
  if (const StoreStatus s = retry_busy([&] { return ensure_session(keyframe.key.session, keyframe.utime); }); !s.ok())
    return failed("session " + std::to_string(keyframe.key.session), s);
  const StoreStatus s = retry_busy([&] { return store_.put_keyframe(MapKeyframe{keyframe, T_map_sensor, map_cloud}); });
  if (!s.ok()) return failed("keyframe " + to_string(keyframe.key), s);
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++stats_.keyframes_written;
  if (map_cloud) stats_.map_cloud_bytes += static_cast<std::int64_t>(map_cloud->size());
}

void MapWriter::on_decision(const LoopDecision& decision) {
  const StoreStatus s = stopped_ ? stopped_status() : retry_busy([&] { return store_.put_loop(to_loop_record(decision)); });
  if (s.ok()) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.decisions_written;
  } else {
    failed("loop event " + std::to_string(decision.event_id), s);
  }
  next_.on_decision(decision);
}

void MapWriter::on_correction(const CorrectionOutput& correction) {
  if (correction_delay_ms_ > 0) std::this_thread::sleep_for(std::chrono::milliseconds(correction_delay_ms_));
  // The correction and "its keyframe is decided" in one transaction: a stop between them would leave a correction
  // naming a keyframe that resume removes.
  const CorrectionRecord record = to_correction_record(correction);
  auto transaction = [&] {
    StoreStatus s = store_.begin();
    if (!s.ok()) return s;
    s = store_.put_correction(record);
    if (s.ok()) s = put_alignments(correction.sessions);
    if (s.ok() && !correction.keys.empty()) s = store_.mark_decided(correction.keys.back());
    if (s.ok()) s = store_.commit();
    if (!s.ok()) store_.rollback();
    return s;
  };
  const StoreStatus s = stopped_ ? stopped_status() : retry_busy(transaction);
  if (s.ok()) {
    decided_with_correction_ = true;
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.corrections_written;
  } else {
    failed("correction revision " + std::to_string(correction.revision), s);
  }
  next_.on_correction(correction);
}

void MapWriter::on_keyframe_decided(const KeyframeKey& keyframe) {
  if (!decided_with_correction_) {
    const StoreStatus s = stopped_ ? stopped_status() : retry_busy([&] { return store_.mark_decided(keyframe); });
    if (!s.ok()) failed("keyframe " + to_string(keyframe) + " decided", s);
  }
  decided_with_correction_ = false;
  next_.on_keyframe_decided(keyframe);
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
