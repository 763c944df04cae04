// Resuming a LoopCorrector after a restart: its small state to and from bytes, and restoring it.
#include <cmath>
#include <cstring>

#include "loopd/correction/loop_corrector.hpp"

namespace loopd {
namespace {

constexpr std::uint32_t kResumeMagic = 0x4c435253;  // "SRCL"
constexpr std::uint32_t kResumeVersion = 2;         ///< 2: a pose-graph solve in flight (1, without it, is read too)

void put_u64(std::vector<std::uint8_t>& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

bool get_u64(const std::vector<std::uint8_t>& in, std::size_t* at, std::uint64_t* v) {
  if (in.size() - *at < 8) return false;
  *v = 0;
  for (int i = 0; i < 8; ++i) *v |= static_cast<std::uint64_t>(in[*at + static_cast<std::size_t>(i)]) << (8 * i);
  *at += 8;
  return true;
}

void put_pose(std::vector<std::uint8_t>& out, const Eigen::Isometry3d& T) {
  const Eigen::Matrix4d& m = T.matrix();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      std::uint64_t bits = 0;
      const double v = m(r, c);
      std::memcpy(&bits, &v, sizeof bits);
      put_u64(out, bits);
    }
}

bool get_pose(const std::vector<std::uint8_t>& in, std::size_t* at, Eigen::Isometry3d* T) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      std::uint64_t bits = 0;
      if (!get_u64(in, at, &bits)) return false;
      double v = 0.0;
      std::memcpy(&v, &bits, sizeof v);
      if (!std::isfinite(v)) return false;
      m(r, c) = v;
    }
  T->matrix() = m;
  return true;
}

bool get_i64(const std::vector<std::uint8_t>& in, std::size_t* at, std::int64_t* v) {
  std::uint64_t u = 0;
  if (!get_u64(in, at, &u)) return false;
  *v = static_cast<std::int64_t>(u);
  return true;
}

}  // namespace

std::vector<std::uint8_t> encode_resume_state(const CorrectorResumeState& state) {
  std::vector<std::uint8_t> out;
  put_u64(out, (std::uint64_t{kResumeVersion} << 32) | kResumeMagic);
  put_u64(out, static_cast<std::uint64_t>(state.max_end_index));
  put_u64(out, static_cast<std::uint64_t>(state.last_graph_index));
  put_u64(out, static_cast<std::uint64_t>(state.num_loops));
  put_u64(out, state.closed_spans.size());
  for (const ClosedSpan& span : state.closed_spans) {
    put_u64(out, static_cast<std::uint64_t>(span.first));
    put_u64(out, static_cast<std::uint64_t>(span.second));
  }
  put_u64(out, state.pending ? 1 : 0);
  if (state.pending) {
    const CorrectorResumeState::Pending& p = *state.pending;
    put_u64(out, static_cast<std::uint64_t>(p.poses));
    put_u64(out, static_cast<std::uint64_t>(p.loops));
    put_u64(out, static_cast<std::uint64_t>(p.planes));
    put_u64(out, static_cast<std::uint64_t>(p.spans));
    put_u64(out, p.solve_again ? 1 : 0);
    put_u64(out, p.warm.size());
    for (const Eigen::Isometry3d& T : p.warm) put_pose(out, T);
  }
  return out;
}

DecodedResumeState decode_resume_state(const std::vector<std::uint8_t>& bytes) {
  DecodedResumeState r;
  std::size_t at = 0;
  std::uint64_t header = 0, spans = 0;
  if (!get_u64(bytes, &at, &header) || static_cast<std::uint32_t>(header) != kResumeMagic) {
    r.error = "corrector state: not a corrector state";
    return r;
  }
  const std::uint64_t version = header >> 32;
  if (version != 1 && version != kResumeVersion) {
    r.error = "corrector state: version " + std::to_string(header >> 32) + ", this loopd reads " + std::to_string(kResumeVersion);
    return r;
  }
  CorrectorResumeState& s = r.state;
  if (!get_i64(bytes, &at, &s.max_end_index) || !get_i64(bytes, &at, &s.last_graph_index) || !get_i64(bytes, &at, &s.num_loops) ||
      !get_u64(bytes, &at, &spans) || spans > (bytes.size() - at) / 16 || s.num_loops < 0) {
    r.error = "corrector state: truncated or inconsistent (" + std::to_string(bytes.size()) + " bytes)";
    return r;
  }
  s.closed_spans.resize(static_cast<std::size_t>(spans));
  for (ClosedSpan& span : s.closed_spans) {
    get_i64(bytes, &at, &span.first);
    get_i64(bytes, &at, &span.second);
  }
  std::uint64_t pending = 0;
  if (version >= 2 && (!get_u64(bytes, &at, &pending) || pending > 1)) {
    r.error = "corrector state: truncated or inconsistent (" + std::to_string(bytes.size()) + " bytes)";
    return r;
  }
  if (pending) {
    CorrectorResumeState::Pending p;
    std::uint64_t again = 0, warm = 0;
    constexpr std::size_t kPoseBytes = 96;
    if (!get_i64(bytes, &at, &p.poses) || !get_i64(bytes, &at, &p.loops) || !get_i64(bytes, &at, &p.planes) || !get_i64(bytes, &at, &p.spans) ||
        !get_u64(bytes, &at, &again) || !get_u64(bytes, &at, &warm) || again > 1 || warm > (bytes.size() - at) / kPoseBytes || p.poses < 1 ||
        static_cast<std::uint64_t>(p.poses) != warm || p.loops < 1 || p.planes < 0 || p.spans < 0) {
      r.error = "corrector state: the solve in flight is truncated or inconsistent";
      return r;
    }
    p.solve_again = again == 1;
    p.warm.resize(static_cast<std::size_t>(warm));
    for (Eigen::Isometry3d& T : p.warm)
      if (!get_pose(bytes, &at, &T)) {
        r.error = "corrector state: a starting pose of the solve in flight is not finite";
        return r;
      }
    s.pending = std::move(p);
  }
  if (at != bytes.size()) {
    r.error = "corrector state: " + std::to_string(bytes.size() - at) + " trailing bytes";
    return r;
  }
  r.ok = true;
  return r;
}

CorrectorResumeState LoopCorrector::resume_state() const {
  CorrectorResumeState s;
  s.closed_spans = closed_spans_;
  s.max_end_index = max_end_index_;
  s.last_graph_index = last_graph_index_;
  s.num_loops = static_cast<std::int64_t>(loops_.size());
  if (pending_) s.pending = pending_->snapshot;
  return s;
}

std::optional<std::string> LoopCorrector::resume(const std::vector<LoopConstraint>& loops, const std::vector<Eigen::Isometry3d>& corrected,
                                                 const CorrectorResumeState& state) {
  const auto n = static_cast<PoseIndex>(odometry_.size());
  if (corrected.size() != odometry_.size())
    return "resume: " + std::to_string(corrected.size()) + " corrected poses for " + std::to_string(odometry_.size()) + " keyframes";
  if (static_cast<std::int64_t>(loops.size()) != state.num_loops)
    return "resume: " + std::to_string(loops.size()) + " loops, the state covers " + std::to_string(state.num_loops);
  for (const LoopConstraint& l : loops)
    if (auto why = check_loop(l)) return "resume: " + *why;
  for (const ClosedSpan& span : state.closed_spans)
    if (span.first < 0 || span.second >= n || span.first > span.second) return "resume: closed span out of range";
  if (state.max_end_index >= n || state.last_graph_index >= n) return "resume: loop end out of range";
  if (const auto& p = state.pending) {
    if (p->poses > n || p->loops > state.num_loops || p->planes > static_cast<std::int64_t>(planes_.size()) ||
        p->spans > static_cast<std::int64_t>(state.closed_spans.size()) || p->warm.size() != static_cast<std::size_t>(p->poses))
      return "resume: the pose-graph solve in flight does not fit the map";
  }
  drop_pending();
  loops_ = loops;
  corrected_ = corrected;
  closed_spans_ = state.closed_spans;
  max_end_index_ = state.max_end_index;
  last_graph_index_ = state.last_graph_index;
  if (state.pending) start_graph(*state.pending);  // the same solve again, applied at the same keyframe
  return std::nullopt;
}

}  // namespace loopd
