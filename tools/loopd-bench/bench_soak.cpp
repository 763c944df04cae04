// loopd-bench soak: the real daemon binary, live on LCM multicast through loopback, fed a looping drive for N minutes.
// Every 10 s it reads the daemon's RSS, threads and open file descriptors from /proc; it listens to LOOP_EVENT and
// LOOPD_STATUS for scan-to-event latency and the keyframe count. Reports a table per window, the RSS slope once keyframe
// growth is taken out, a PNG of RSS and keyframes over time, and the daemon's exit code after SIGTERM.
//
// The bench publishes the drive itself (no lcm-logplayer), so it knows the wall time at which each scan went out:
// latency = decision wall time (loop_event_t.utime, the daemon's clock on the same machine) - publish wall time of the
// scan whose utime is the event's query_utime, for the first verified decision (stage other than "descriptor") of
// each query keyframe, as loopd-bench pipeline counts it.
//
// One continuous drive: the drive is cut where it returns to its start (ground truth, else odometry), and each
// further loop is shifted forward in time (utime + k * loop span) with its odometry chained onto the end of the
// previous loop (T_k+1 = T_k * T_odom(cut) * T_odom(start)^-1), sequence numbers continued. So loopd sees one drive
// that revisits the same places lap after lap with odometry drift growing, as a weeks-long run does. After each loop
// the vehicle stands still for --stop-s seconds (the last scan and pose repeated at the scan rate): keyframes then
// stop growing while time goes on, which is what lets the fit separate memory per keyframe from memory per minute.
#include <CLI/CLI.hpp>
#include <Eigen/Dense>
#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include "lcm_log.hpp"
#include "message_convert.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;
using loopd::tools::fmt;
namespace fs = std::filesystem;

namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) { g_interrupted.store(true); }

std::int64_t wall_us() { return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count(); }
double mono_s() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

/// @brief Output of a shell command (stdout and stderr), "" when it cannot run.
std::string shell_output(const std::string& cmd) {
  std::string out;
  if (FILE* p = popen((cmd + " 2>&1").c_str(), "r")) {
    char buf[512];
    while (std::fgets(buf, sizeof buf, p)) out += buf;
    pclose(p);
  }
  return out;
}

/// @brief True when the kernel routes the LCM group through loopback (`ip route get` names "dev lo").
bool multicast_on_loopback(const std::string& group, std::string* route) {
  *route = shell_output("ip route get " + group);
  return route->find(" dev lo ") != std::string::npos || route->find(" dev lo\n") != std::string::npos;
}

/// @brief A program next to this binary's build tree (build/<rel>), next to the binary itself (installed), else "".
std::string find_program(const std::string& build_rel, const std::string& name) {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path dir = self.parent_path();
    for (const fs::path& p : {dir.parent_path().parent_path() / build_rel, dir / name})
      if (fs::exists(p, ec)) return p.string();
  }
  return "";
}

// ---------------------------------------------------------------------------------------------------------------
// Process figures from /proc.

struct ProcFigures {
  std::int64_t rss_bytes = -1;
  int threads = -1;
  int fds = -1;
};

ProcFigures read_proc(pid_t pid) {
  ProcFigures f;
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) f.rss_bytes = std::stoll(line.substr(6)) * 1024;  // "VmRSS:   123456 kB"
    if (line.rfind("Threads:", 0) == 0) f.threads = std::stoi(line.substr(8));
  }
  std::error_code ec;
  int n = 0;
  for (fs::directory_iterator it("/proc/" + std::to_string(pid) + "/fd", ec), end; !ec && it != end; it.increment(ec)) ++n;
  if (!ec) f.fds = n;
  return f;
}

// ---------------------------------------------------------------------------------------------------------------
// The drive and its loop plan.

Eigen::Isometry3d pose_of(const pose_t& m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(m.orientation[0], m.orientation[1], m.orientation[2], m.orientation[3]).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(m.position[0], m.position[1], m.position[2]);
  return T;
}

void set_pose(const Eigen::Isometry3d& T, pose_t* m) {
  const Eigen::Quaterniond q(T.rotation());
  for (int i = 0; i < 3; ++i) m->position[i] = T.translation()[i];
  m->orientation[0] = q.w();
  m->orientation[1] = q.x();
  m->orientation[2] = q.y();
  m->orientation[3] = q.z();
}

/// @brief Where one loop of the drive ends and how the next one continues it.
struct LoopPlan {
  std::int64_t first_utime = 0;          ///< utime of the first scan or pose
  std::int64_t cut_utime = 0;            ///< events with utime < cut_utime make one loop; the next loop starts here
  std::int64_t scan_period_us = 100000;  ///< median scan interval (the stop repeats the last scan at this rate)
  Eigen::Isometry3d odom_first = Eigen::Isometry3d::Identity(), odom_cut = Eigen::Isometry3d::Identity();
  std::int64_t scans_per_loop = 0, poses_per_loop = 0;
  double return_gap_m = 0.0;  ///< distance between the start and the cut (ground truth, else odometry)
  bool from_ground_truth = false;
  std::string error;
};

/// @brief Reads the drive's poses and scan times and cuts it where it comes back to its start (searched in the second
///        half, heading within 45 deg); the whole drive when it never comes back within 3 m.
LoopPlan plan_loop(const std::string& path) {
  LoopPlan plan;
  LogReader reader;
  if (!reader.open(path, &plan.error)) return plan;
  struct P {
    std::int64_t utime;
    Eigen::Isometry3d T;
  };
  std::vector<P> odom, truth;
  std::vector<std::int64_t> scans;
  LogEvent ev;
  while (reader.next(&ev)) {
    if (ev.channel == channels::kScan) {
      point_cloud_t m;
      if (LogReader::decode(ev, &m)) scans.push_back(m.utime);
    } else if (ev.channel == channels::kPose || ev.channel == channels::kGroundTruth) {
      pose_t m;
      if (!LogReader::decode(ev, &m)) continue;
      (ev.channel == channels::kPose ? odom : truth).push_back({m.utime, pose_of(m)});
    }
  }
  if (scans.size() < 10 || odom.size() < 10) {
    plan.error = path + ": needs at least 10 scans on " + channels::kScan + " and 10 poses on " + channels::kPose;
    return plan;
  }
  std::vector<std::int64_t> gaps;
  for (std::size_t i = 1; i < scans.size(); ++i) gaps.push_back(scans[i] - scans[i - 1]);
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
  plan.scan_period_us = std::max<std::int64_t>(1000, gaps[gaps.size() / 2]);
  plan.first_utime = std::min(scans.front(), odom.front().utime);

  plan.from_ground_truth = truth.size() >= 10;
  const std::vector<P>& path_poses = plan.from_ground_truth ? truth : odom;
  std::size_t best = path_poses.size();
  double best_d = 1e300;
  for (std::size_t i = path_poses.size() / 2; i < path_poses.size(); ++i) {
    const Eigen::Isometry3d d = path_poses.front().T.inverse() * path_poses[i].T;
    const double yaw = std::abs(std::atan2(d.linear()(1, 0), d.linear()(0, 0)));
    const double dist = d.translation().head<2>().norm();
    if (yaw < M_PI / 4 && dist < best_d) {
      best_d = dist;
      best = i;
    }
  }
  // Within 3 m: a lap end. Otherwise loop the whole drive (each loop then jumps back to the start place).
  const auto odom_at = [&](std::int64_t utime) {
    const auto it = std::lower_bound(odom.begin(), odom.end(), utime, [](const P& p, std::int64_t u) { return p.utime < u; });
    return it == odom.end() ? odom.back().T : it->T;
  };
  plan.odom_first = odom.front().T;
  if (best < path_poses.size() && best_d <= 3.0) {
    plan.cut_utime = path_poses[best].utime;
    plan.odom_cut = odom_at(plan.cut_utime);
    plan.return_gap_m = best_d;
  } else {
    plan.cut_utime = std::max(scans.back(), odom.back().utime) + plan.scan_period_us;
    plan.odom_cut = odom.back().T;
    plan.return_gap_m = (path_poses.front().T.translation() - path_poses.back().T.translation()).norm();
  }
  plan.scans_per_loop = std::count_if(scans.begin(), scans.end(), [&](std::int64_t u) { return u < plan.cut_utime; });
  plan.poses_per_loop = std::count_if(odom.begin(), odom.end(), [&](const P& p) { return p.utime < plan.cut_utime; });
  return plan;
}

// ---------------------------------------------------------------------------------------------------------------
// What the bench hears from the daemon, and when it published each scan.

struct LatencySample {
  double t_s;  ///< seconds since the start of the soak (receive time)
  double ms;
};

class Listener {
 public:
  explicit Listener(double t0_mono) : t0_(t0_mono) {}

  void published(std::int64_t scan_utime, std::int64_t wall) {
    std::lock_guard<std::mutex> lock(mutex_);
    publish_wall_[scan_utime] = wall;
    // Bounded: a decision comes within seconds of its scan; keep the last 100000 scans (~3 h at 10 Hz).
    while (publish_wall_.size() > 100000) publish_wall_.erase(publish_wall_.begin());
  }

  void on_event(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    loop_event_t e;
    if (!decode_bounded(rbuf->data, rbuf->data_size, DecodeLimits{}, &e).ok) {
      ++malformed_;
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    const double t = mono_s() - t0_;
    event_times_.push_back(t);
    accepted_ += e.status == loop_event_t::STATUS_ACCEPTED ? 1 : 0;
    if (e.stage == "descriptor" || !verified_.insert(e.query_utime).second) return;
    while (verified_.size() > 100000) verified_.erase(verified_.begin());
    const auto it = publish_wall_.find(e.query_utime);
    if (it == publish_wall_.end()) {
      ++unmatched_;
      return;
    }
    latency_.push_back({t, static_cast<double>(e.utime - it->second) * 1e-3});
  }

  void on_status(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    status_t s;
    if (!decode_bounded(rbuf->data, rbuf->data_size, DecodeLimits{}, &s).ok) {
      ++malformed_;
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    status_ = s;
    has_status_ = true;
  }

  bool status(status_t* out) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (has_status_) *out = status_;
    return has_status_;
  }
  std::vector<double> event_times() {
    std::lock_guard<std::mutex> lock(mutex_);
    return event_times_;
  }
  std::vector<LatencySample> latency() {
    std::lock_guard<std::mutex> lock(mutex_);
    return latency_;
  }
  std::int64_t accepted() {
    std::lock_guard<std::mutex> lock(mutex_);
    return accepted_;
  }
  std::int64_t unmatched() {
    std::lock_guard<std::mutex> lock(mutex_);
    return unmatched_;
  }
  std::int64_t malformed() const { return malformed_.load(); }

 private:
  double t0_;
  std::mutex mutex_;
  std::map<std::int64_t, std::int64_t> publish_wall_;
  std::set<std::int64_t> verified_;
  std::vector<double> event_times_;
  std::vector<LatencySample> latency_;
  std::int64_t accepted_ = 0, unmatched_ = 0;
  std::atomic<std::int64_t> malformed_{0};
  status_t status_{};
  bool has_status_ = false;
};

// ---------------------------------------------------------------------------------------------------------------
// The publisher: the drive, loop after loop, paced at `speed` x real time.

struct PublishStats {
  std::atomic<std::int64_t> scans{0}, poses{0}, loops{0}, behind{0};
  std::atomic<bool> failed{false};
  std::string error;  ///< read only after the publisher has ended
};

template <typename Msg>
bool publish_msg(lcm::LCM& lcm, const std::string& channel, const Msg& m, std::vector<std::uint8_t>* buf) {
  buf->resize(static_cast<std::size_t>(m.getEncodedSize()));
  if (m.encode(buf->data(), 0, static_cast<int>(buf->size())) < 0) return false;
  return lcm.publish(channel, buf->data(), static_cast<unsigned int>(buf->size())) == 0;
}

void publish_loops(const std::string& url, const std::string& drive, const LoopPlan& plan, double speed, double stop_s, Listener* listener,
                   const std::atomic<bool>* stop, PublishStats* stats) {
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    stats->error = "cannot open LCM for publishing on " + url;
    stats->failed = true;
    return;
  }
  const double wall0 = mono_s();
  const auto pace = [&](std::int64_t data_utime) {  // sleeps until this data time is due; false when stopped
    const double due = wall0 + static_cast<double>(data_utime - plan.first_utime) * 1e-6 / speed;
    for (;;) {
      if (stop->load()) return false;
      const double wait = due - mono_s();
      if (wait <= 0) {
        if (wait < -1.0) ++stats->behind;
        return true;
      }
      std::this_thread::sleep_for(std::chrono::duration<double>(std::min(wait, 0.2)));
    }
  };
  const std::int64_t span = plan.cut_utime - plan.first_utime;
  const std::int64_t stop_steps = static_cast<std::int64_t>(std::llround(stop_s * 1e6 / static_cast<double>(plan.scan_period_us)));
  const Eigen::Isometry3d step = plan.odom_cut * plan.odom_first.inverse();
  std::vector<std::uint8_t> buf;
  Eigen::Isometry3d chain = Eigen::Isometry3d::Identity();  // T_k: maps the drive's odometry onto loop k's
  std::int64_t offset = 0;                                  // utime shift of loop k
  for (std::int64_t k = 0; !stop->load(); ++k) {
    LogReader reader;
    std::string error;
    if (!reader.open(drive, &error)) {
      stats->error = error;
      stats->failed = true;
      return;
    }
    point_cloud_t last_scan;
    pose_t last_pose;
    bool have_scan = false, have_pose = false;
    LogEvent ev;
    while (!stop->load() && reader.next(&ev)) {
      if (ev.channel == channels::kScan) {
        point_cloud_t m;
        if (!LogReader::decode(ev, &m) || m.utime >= plan.cut_utime) continue;
        last_scan = std::move(m);
        last_scan.utime += offset;
        last_scan.seq += k * plan.scans_per_loop;
        if (!pace(last_scan.utime)) break;
        publish_msg(lcm, channels::kScan, last_scan, &buf);
        listener->published(last_scan.utime, wall_us());
        ++stats->scans;
        have_scan = true;
      } else if (ev.channel == channels::kPose) {
        pose_t m;
        if (!LogReader::decode(ev, &m) || m.utime >= plan.cut_utime) continue;
        last_pose = m;
        last_pose.utime += offset;
        last_pose.seq += k * plan.poses_per_loop;
        set_pose(chain * pose_of(last_pose), &last_pose);
        if (!pace(last_pose.utime)) break;
        publish_msg(lcm, channels::kPose, last_pose, &buf);
        ++stats->poses;
        have_pose = true;
      }
    }
    // Standing still: the last pose and scan again at the scan rate (a pose first, as the drive has them).
    for (std::int64_t i = 0; i < stop_steps && have_scan && have_pose && !stop->load(); ++i) {
      const std::int64_t utime = plan.cut_utime + offset + i * plan.scan_period_us;
      last_pose.utime = utime;
      last_scan.utime = utime;
      ++last_pose.seq;
      ++last_scan.seq;
      if (!pace(utime)) break;
      publish_msg(lcm, channels::kPose, last_pose, &buf);
      publish_msg(lcm, channels::kScan, last_scan, &buf);
      listener->published(utime, wall_us());
      ++stats->poses;
      ++stats->scans;
    }
    ++stats->loops;
    offset += span + stop_steps * plan.scan_period_us;
    chain = chain * step;
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Figures.

struct Sample {
  double t_s = 0;
  ProcFigures proc;
  std::int64_t keyframes = 0, bytes_per_keyframe = 0, shed = 0, loops_accepted = 0, scans_lost = 0, dropped = 0;
  std::int64_t scans_published = 0;
};

double p99(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(v.size()))) - 1)];
}

/// @brief Least squares y = a + b t + c k over the samples; also the correlation of t and k (near 1: b and c cannot
///        be told apart).
struct RssFit {
  bool ok = false;
  double mb_per_min = 0, kb_per_keyframe = 0, intercept_mb = 0, t_k_correlation = 0, rms_mb = 0;
  double mb_per_min_se = 0, kb_per_keyframe_se = 0;  ///< standard errors of the two slopes
  double plain_mb_per_min = 0;                       ///< RSS against time alone
  double residual_mb_per_min = 0;                    ///< (RSS - keyframes * status bytes_per_keyframe) against time
  int samples = 0;
};

RssFit fit_rss(const std::vector<Sample>& all, double from_s) {
  RssFit f;
  std::vector<const Sample*> s;
  for (const auto& x : all)
    if (x.t_s >= from_s && x.proc.rss_bytes > 0) s.push_back(&x);
  f.samples = static_cast<int>(s.size());
  if (s.size() < 4) return f;
  const auto n = static_cast<Eigen::Index>(s.size());
  Eigen::MatrixXd A(n, 3), A1(n, 2);
  Eigen::VectorXd y(n), r(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Sample& x = *s[static_cast<std::size_t>(i)];
    const double mb = static_cast<double>(x.proc.rss_bytes) / 1e6;
    A.row(i) << 1.0, x.t_s / 60.0, static_cast<double>(x.keyframes);
    A1.row(i) << 1.0, x.t_s / 60.0;
    y(i) = mb;
    r(i) = mb - static_cast<double>(x.keyframes * x.bytes_per_keyframe) / 1e6;
  }
  const Eigen::VectorXd c = A.colPivHouseholderQr().solve(y);
  f.intercept_mb = c(0);
  f.mb_per_min = c(1);
  f.kb_per_keyframe = c(2) * 1e3;
  f.rms_mb = std::sqrt((A * c - y).squaredNorm() / static_cast<double>(n));
  // Covariance of the coefficients: sigma^2 (A^T A)^-1 with sigma^2 = residual sum of squares / (n - 3).
  const Eigen::Matrix3d cov = (A.transpose() * A).inverse() * ((A * c - y).squaredNorm() / static_cast<double>(n - 3));
  f.mb_per_min_se = std::sqrt(std::max(0.0, cov(1, 1)));
  f.kb_per_keyframe_se = std::sqrt(std::max(0.0, cov(2, 2))) * 1e3;
  f.plain_mb_per_min = A1.colPivHouseholderQr().solve(y)(1);
  f.residual_mb_per_min = A1.colPivHouseholderQr().solve(r)(1);
  const Eigen::VectorXd t = A.col(1).array() - A.col(1).mean(), k = A.col(2).array() - A.col(2).mean();
  const double den = std::sqrt(t.squaredNorm() * k.squaredNorm());
  f.t_k_correlation = den > 0 ? t.dot(k) / den : 1.0;
  f.ok = true;
  return f;
}

struct Window {
  double from_min = 0, to_min = 0;
  double rss_mb = 0;
  std::int64_t keyframes = 0;
  int threads = 0, fds = 0;
  double p99_ms = 0;
  std::size_t latency_n = 0, events = 0;
};

/// Every verified keyframe's latency in OUT/latency.dat, to see whether slow ones come alone or in runs (a stall and
/// the queue behind it).
void write_latency(const std::string& out_dir, const std::vector<LatencySample>& latency) {
  std::ofstream f(out_dir + "/latency.dat");
  f << "# seconds_since_start latency_ms\n";
  for (const auto& l : latency) f << l.t_s << ' ' << l.ms << '\n';
}

std::vector<Window> make_windows(const std::vector<Sample>& samples, const std::vector<double>& events, const std::vector<LatencySample>& latency,
                                 double window_s, double total_s) {
  std::vector<Window> out;
  for (double from = 0; from < total_s - 1e-6; from += window_s) {
    double to = std::min(total_s, from + window_s);
    if (total_s - to < 0.1 * window_s) to = total_s;  // a sliver at the end joins the last window
    const bool last_window = to >= total_s;
    const double to_events = last_window ? 1e300 : to;  // decisions heard while loopd drains count in the last window
    Window w;
    w.from_min = from / 60.0;
    w.to_min = to / 60.0;
    const Sample* last = nullptr;
    for (const auto& s : samples)
      if (s.t_s > from - 1e-6 && s.t_s <= to + 1.0) {  // the window's samples; figures at its end, maxima of threads/fds
        last = &s;
        w.threads = std::max(w.threads, s.proc.threads);
        w.fds = std::max(w.fds, s.proc.fds);
      }
    if (last) {
      w.rss_mb = static_cast<double>(last->proc.rss_bytes) / 1e6;
      w.keyframes = last->keyframes;
    }
    std::vector<double> ms;
    for (const auto& l : latency)
      if (l.t_s >= from && l.t_s < to_events) ms.push_back(l.ms);
    w.p99_ms = p99(ms);
    w.latency_n = ms.size();
    w.events = static_cast<std::size_t>(std::count_if(events.begin(), events.end(), [&](double t) { return t >= from && t < to_events; }));
    out.push_back(w);
    if (last_window) break;
  }
  return out;
}

/// @brief soak.dat, soak.gp and the PNG (RSS and keyframes over minutes) with gnuplot; "" and `error` when it fails.
std::string write_plot(const std::string& dir, const std::vector<Sample>& samples, std::string* error) {
  const std::string dat = dir + "/soak.dat", gp = dir + "/soak.gp", png = dir + "/soak_rss.png";
  {
    std::ofstream f(dat);
    f << "# minutes rss_mb keyframes threads fds scans_published\n";
    for (const auto& s : samples)
      f << s.t_s / 60.0 << ' ' << static_cast<double>(s.proc.rss_bytes) / 1e6 << ' ' << s.keyframes << ' ' << s.proc.threads << ' ' << s.proc.fds
        << ' ' << s.scans_published << '\n';
  }
  {
    std::ofstream f(gp);
    f << "set terminal pngcairo size 1000,560 font ',10'\nset output '" << png << "'\n"
      << "set title 'loopd soak: resident memory and keyframes'\nset xlabel 'minutes'\nset ylabel 'RSS [MB]'\n"
      << "set y2label 'keyframes'\nset y2tics\nset ytics nomirror\nset grid\nset key left top\n"
      << "plot '" << dat << "' using 1:2 with linespoints pt 7 ps 0.5 lw 2 lc rgb '#c03020' title 'RSS [MB]', "
      << "'' using 1:3 axes x1y2 with lines lw 2 lc rgb '#3060d0' title 'keyframes'\n";
  }
  const int rc = std::system(("gnuplot '" + gp + "' 2>'" + dir + "/gnuplot.log'").c_str());
  std::error_code ec;
  if (rc != 0 || !fs::exists(png, ec) || fs::file_size(png, ec) == 0) {
    *error = "gnuplot failed (see " + dir + "/gnuplot.log); the data is in " + dat;
    return "";
  }
  return png;
}

pid_t spawn_daemon(const std::vector<std::string>& args, const std::string& log_path) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      close(fd);
    }
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

/// @brief Exit code of a waited-for process: its status, 128 + signal when killed.
int exit_code(int status) { return WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1; }

std::string last_line(const std::string& path) {
  std::ifstream f(path);
  std::string line, last;
  while (std::getline(f, line))
    if (!line.empty()) last = line;
  return last;
}

/// @brief The command line.
struct SoakOptions {
  double minutes = 30.0, speed = 1.0, poll_s = 10.0, window_min = 5.0, stop_s = 10.0, warmup_min = 1.0, term_timeout_s = 60.0;
  std::string drive, sensor = "vlp16", loopd_bin, sim_bin, out_dir = (fs::temp_directory_path() / "loopd-soak").string();
  int port = 7600 + static_cast<int>(getpid() % 60), threads = -1, sim_scans = 400;
  bool json = false;
};

void add_options(CLI::App& app, SoakOptions& o) {
  app.add_option("--minutes", o.minutes, "how long to run; the bench stops itself after this")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 100000.0));
  app.add_option("--drive", o.drive,
                 "lcm-logger drive with LIDAR_SCAN and ODOMETRY_POSE (GROUND_TRUTH_POSE helps to cut laps); "
                 "default: generated with loopd-sim into --out");
  app.add_option("--speed", o.speed, "play speed, 1 = real time")->capture_default_str()->check(CLI::Range(0.01, 100.0));
  app.add_option("--sensor", o.sensor, "lidar preset for loopd (and loopd-sim)")->capture_default_str();
  app.add_option("--loopd", o.loopd_bin, "loopd binary (default: build/daemon/loopd beside this build, or next to this binary)");
  app.add_option("--loopd-sim", o.sim_bin, "loopd-sim binary for the default drive");
  app.add_option("--sim-scans", o.sim_scans, "scans of the generated drive (block route: ~250 scans a lap)")->capture_default_str();
  app.add_option("--threads", o.threads, "loopd worker threads (-1 = loopd's default)")->capture_default_str();
  app.add_option("--port", o.port, "UDP port on 239.255.76.67 (ttl=0, loopback only)")->capture_default_str()->check(CLI::Range(1024, 65535));
  app.add_option("--poll-s", o.poll_s, "seconds between samples of the daemon process")->capture_default_str()->check(CLI::Range(1.0, 600.0));
  app.add_option("--window-min", o.window_min, "minutes per table row")->capture_default_str()->check(CLI::Range(0.1, 10000.0));
  app.add_option("--stop-s", o.stop_s, "seconds the vehicle stands still after each loop (0: none)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 3600.0));
  app.add_option("--warmup-min", o.warmup_min, "minutes left out of the RSS fit (start-up allocations)")->capture_default_str();
  app.add_option("--out", o.out_dir, "folder for the generated drive, loopd.log, soak.dat, latency.dat and soak_rss.png")->capture_default_str();
  app.add_flag("--json", o.json, "one JSON object as the last stdout line");
}

/// @brief Checks the LCM group stays on this machine, creates the output folder, finds loopd and makes the drive when
///        none is given. Returns the exit status when it cannot.
std::optional<int> prepare_soak(SoakOptions& o, std::string* url) {
  const std::string group = "239.255.76.67";
  *url = "udpm://" + group + ":" + std::to_string(o.port) + "?ttl=0&recv_buf_size=8388608";
  std::string route;
  if (!multicast_on_loopback(group, &route)) {
    std::cerr << "loopd-bench soak: refusing to run: the LCM group " << group << " is not routed through loopback, so the soak's\n"
              << "multicast would leave this machine. As root: ip link set lo multicast on; ip route replace 239.255.76.0/24 dev lo\n"
              << "(scripts/test does this). 'ip route get " << group << "' says: " << route;
    return 2;
  }
  std::error_code ec;
  fs::create_directories(o.out_dir, ec);
  if (ec) {
    std::cerr << "loopd-bench soak: cannot create " << o.out_dir << ": " << ec.message() << "\n";
    return 1;
  }
  if (o.loopd_bin.empty()) o.loopd_bin = find_program("daemon/loopd", "loopd");
  if (o.loopd_bin.empty() || access(o.loopd_bin.c_str(), X_OK) != 0) {
    std::cerr << "loopd-bench soak: no loopd binary (looked for build/daemon/loopd beside this build and loopd next to this binary); "
                 "give --loopd PATH\n";
    return 1;
  }
  if (o.drive.empty()) {
    o.drive = o.out_dir + "/drive_" + o.sensor + "_" + std::to_string(o.sim_scans) + ".lcmlog";
    if (!fs::exists(o.drive, ec)) {
      if (o.sim_bin.empty()) o.sim_bin = find_program("tools/loopd-sim/loopd-sim", "loopd-sim");
      if (o.sim_bin.empty()) {
        std::cerr << "loopd-bench soak: no --drive and no loopd-sim found (give --loopd-sim PATH)\n";
        return 1;
      }
      std::cerr << "loopd-bench soak: generating " << o.drive << " with loopd-sim\n";
      const std::string cmd = "'" + o.sim_bin + "' --out '" + o.drive + ".part' --sensor " + o.sensor + " --scans " + std::to_string(o.sim_scans) +
                              " --seed 11 --route block --quiet >/dev/null";
      if (std::system(cmd.c_str()) != 0 || !fs::exists(o.drive + ".part", ec)) {
        std::cerr << "loopd-bench soak: loopd-sim failed: " << cmd << "\n";
        return 1;
      }
      fs::rename(o.drive + ".part", o.drive, ec);
    }
  }
  return std::nullopt;
}

/// @brief How the daemon ended: SIGTERM, then a wait (SIGKILL after term_timeout_s, reported as such).
struct DaemonEnd {
  int rc = -1;
  bool killed = false;
  double term_s = 0;
};

DaemonEnd stop_daemon(pid_t pid, double term_timeout_s) {
  DaemonEnd end;
  const double t_term = mono_s();
  kill(pid, SIGTERM);
  int status = 0;
  for (;;) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      end.rc = exit_code(status);
      break;
    }
    if (mono_s() - t_term > term_timeout_s) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      end.rc = exit_code(status);
      end.killed = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  end.term_s = mono_s() - t_term;
  return end;
}

/// @brief One sample of the daemon process and of its newest status, printed as a progress line.
Sample sample_daemon(pid_t pid, Listener& listener, const PublishStats& pub, double t) {
  Sample s;
  s.t_s = t;
  s.proc = read_proc(pid);
  status_t st;
  if (listener.status(&st)) {
    s.keyframes = st.keyframes;
    s.bytes_per_keyframe = st.bytes_per_keyframe;
    s.shed = st.shed;
    s.loops_accepted = st.loops_accepted;
    s.scans_lost = st.scans_lost_estimate;
    for (int i = 0; i < st.num_channels; ++i) s.dropped += st.channels[static_cast<std::size_t>(i)].dropped;
  }
  s.scans_published = pub.scans.load();
  std::cerr << "loopd-bench soak: " << fmt(t / 60.0, 1) << " min: RSS " << fmt(static_cast<double>(s.proc.rss_bytes) / 1e6, 0) << " MB, keyframes "
            << s.keyframes << ", threads " << s.proc.threads << ", fds " << s.proc.fds << ", scans published " << s.scans_published
            << ", loops played " << pub.loops.load() << "\n";
  return s;
}

void describe_plan(const LoopPlan& plan, double stop_s, const std::string& url) {
  const double loop_s = static_cast<double>(plan.cut_utime - plan.first_utime) * 1e-6;
  std::cerr << "loopd-bench soak: one loop = " << plan.scans_per_loop << " scans, " << fmt(loop_s, 1) << " s of drive, returns within "
            << fmt(plan.return_gap_m, 2) << " m of its start (" << (plan.from_ground_truth ? "ground truth" : "odometry") << "), then "
            << fmt(stop_s, 0) << " s standing still; " << url << "\n";
  if (plan.return_gap_m > 3.0)
    std::cerr << "loopd-bench soak: warning: the drive does not come back to its start; each loop jumps " << fmt(plan.return_gap_m, 1)
              << " m in space (odometry stays continuous)\n";
}

void print_windows(const std::vector<Window>& windows) {
  tools::Table t({"minutes", "RSS [MB]", "keyframes", "threads", "fds", "p99 latency [ms]", "verified", "events"});
  for (const auto& w : windows)
    t.add({fmt(w.from_min, 1) + "-" + fmt(w.to_min, 1), fmt(w.rss_mb, 0), std::to_string(w.keyframes), std::to_string(w.threads),
           std::to_string(w.fds), w.latency_n ? fmt(w.p99_ms, 0) : "-", std::to_string(w.latency_n), std::to_string(w.events)});
  std::cout << t.str();
}

/// @brief Starts loopd on the soak's URL, its output into daemon_log, and catches SIGINT / SIGTERM for the bench
///        itself (it stops the run, not the process). Returns its pid, <= 0 when it could not start.
pid_t start_loopd(const SoakOptions& o, const std::string& url, const std::string& daemon_log) {
  std::vector<std::string> args = {o.loopd_bin, "--sensor", o.sensor, "--quiet", "--lcm-url", url};
  if (o.threads >= 0) args.insert(args.end(), {"--threads", std::to_string(o.threads)});
  const pid_t pid = spawn_daemon(args, daemon_log);
  if (pid <= 0) {
    std::cerr << "loopd-bench soak: cannot start " << o.loopd_bin << "\n";
    return pid;
  }
  struct sigaction sa {};
  sa.sa_handler = on_interrupt;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  return pid;
}

/// @brief The first sample at or after t [s] (the first one when none is).
const Sample& first_after(const std::vector<Sample>& samples, double t) {
  for (const auto& s : samples)
    if (s.t_s >= t) return s;
  return samples.front();
}

/// @brief Everything the soak measured, for its JSON line.
struct SoakFigures {
  double run_s = 0;
  std::vector<Window> windows;
  RssFit fit;
  tools::Summary lat;
  double p99_ms = 0;
  std::size_t events = 0;
  Sample first, last;
  std::string png, url;
  int daemon_rc = -1;
  bool daemon_died = false, killed = false;
  Sample after_warmup;
  std::int64_t accepted_heard = 0;
  double term_s = 0;
  std::string plot_error, daemon_log;
};

void print_soak_summary(const SoakOptions& o, const SoakFigures& f, const PublishStats& pub) {
  tools::Table s({"figure", "value"});
  s.add({"run [min] / speed", fmt(f.run_s / 60.0, 1) + " / " + fmt(o.speed, 2) + "x"});
  s.add({"loops played / scans published", std::to_string(pub.loops.load()) + " / " + std::to_string(pub.scans.load())});
  s.add({"keyframes / loops accepted (status)", std::to_string(f.last.keyframes) + " / " + std::to_string(f.last.loops_accepted)});
  s.add({"RSS start / after warm-up / end [MB]", fmt(static_cast<double>(f.first.proc.rss_bytes) / 1e6, 0) + " / " +
                                                     fmt(static_cast<double>(f.after_warmup.proc.rss_bytes) / 1e6, 0) + " / " +
                                                     fmt(static_cast<double>(f.last.proc.rss_bytes) / 1e6, 0)});
  if (f.fit.ok) {
    s.add({"RSS fit: MB/min (keyframes taken out)", fmt(f.fit.mb_per_min, 3) + " +- " + fmt(f.fit.mb_per_min_se, 3)});
    s.add({"RSS fit: KB per keyframe", fmt(f.fit.kb_per_keyframe, 1) + " +- " + fmt(f.fit.kb_per_keyframe_se, 1)});
    s.add({"RSS fit: rms [MB] / samples / corr(time, keyframes)",
           fmt(f.fit.rms_mb, 1) + " / " + std::to_string(f.fit.samples) + " / " + fmt(f.fit.t_k_correlation, 4)});
    s.add({"RSS - keyframes x status bytes/keyframe: MB/min", fmt(f.fit.residual_mb_per_min, 3)});
    s.add({"RSS against time alone: MB/min", fmt(f.fit.plain_mb_per_min, 3)});
  }
  s.add({"threads start / after warm-up / end",
         std::to_string(f.first.proc.threads) + " / " + std::to_string(f.after_warmup.proc.threads) + " / " + std::to_string(f.last.proc.threads)});
  s.add({"fds start / after warm-up / end",
         std::to_string(f.first.proc.fds) + " / " + std::to_string(f.after_warmup.proc.fds) + " / " + std::to_string(f.last.proc.fds)});
  s.add({"latency [ms] median / p95 / p99 / max (n)", fmt(f.lat.median, 0) + " / " + fmt(f.lat.p95, 0) + " / " + fmt(f.p99_ms, 0) + " / " +
                                                          fmt(f.lat.max, 0) + " (" + std::to_string(f.lat.count) + ")"});
  s.add({"events / accepted (heard)", std::to_string(f.events) + " / " + std::to_string(f.accepted_heard)});
  s.add({"shed / dropped / scans lost (status)",
         std::to_string(f.last.shed) + " / " + std::to_string(f.last.dropped) + " / " + std::to_string(f.last.scans_lost)});
  s.add({"publisher > 1 s behind schedule", std::to_string(pub.behind.load())});
  s.add({"loopd exit code after SIGTERM",
         f.daemon_died
             ? "died during the run: " + std::to_string(f.daemon_rc)
             : std::to_string(f.daemon_rc) + (f.killed ? " (SIGKILL after " + fmt(o.term_timeout_s, 0) + " s)" : " (" + fmt(f.term_s, 1) + " s)")});
  s.add({"plot", f.png.empty() ? f.plot_error : f.png});
  std::cout << s.str();
  std::cout << "loopd's last line: " << last_line(f.daemon_log) << "\n";
  if (f.fit.ok && f.fit.mb_per_min_se > 0.1)  // 0.1 MB/min = 144 MB a day
    std::cout << "note: MB/min is only known to +- " << fmt(f.fit.mb_per_min_se, 2) << " (keyframes grew almost in step with time, corr "
              << fmt(f.fit.t_k_correlation, 4) << "); a longer run or a longer --stop-s separates them better\n";
}

void print_soak_json(const SoakOptions& o, const SoakFigures& f, const PublishStats& pub) {
  const auto& windows = f.windows;
  const auto& fit = f.fit;
  const auto& lat = f.lat;
  const Sample &first = f.first, &last = f.last;
  nlohmann::json jw = nlohmann::json::array();
  for (const auto& w : windows)
    jw.push_back({{"from_min", w.from_min},
                  {"to_min", w.to_min},
                  {"rss_mb", w.rss_mb},
                  {"keyframes", w.keyframes},
                  {"threads", w.threads},
                  {"fds", w.fds},
                  {"p99_latency_ms", w.p99_ms},
                  {"verified", w.latency_n},
                  {"events", w.events}});
  nlohmann::json j{{"minutes", f.run_s / 60.0},
                   {"speed", o.speed},
                   {"drive", o.drive},
                   {"url", f.url},
                   {"stop_s", o.stop_s},
                   {"loops_played", pub.loops.load()},
                   {"scans_published", pub.scans.load()},
                   {"keyframes", last.keyframes},
                   {"loops_accepted", last.loops_accepted},
                   {"rss_start_mb", static_cast<double>(first.proc.rss_bytes) / 1e6},
                   {"rss_end_mb", static_cast<double>(last.proc.rss_bytes) / 1e6},
                   {"rss_mb_per_min", fit.mb_per_min},
                   {"rss_mb_per_min_se", fit.mb_per_min_se},
                   {"rss_kb_per_keyframe", fit.kb_per_keyframe},
                   {"rss_kb_per_keyframe_se", fit.kb_per_keyframe_se},
                   {"rss_fit_time_keyframe_correlation", fit.t_k_correlation},
                   {"rss_residual_mb_per_min", fit.residual_mb_per_min},
                   {"rss_plain_mb_per_min", fit.plain_mb_per_min},
                   {"threads_start", first.proc.threads},
                   {"threads_end", last.proc.threads},
                   {"fds_start", first.proc.fds},
                   {"fds_end", last.proc.fds},
                   {"latency_median_ms", lat.median},
                   {"latency_p99_ms", f.p99_ms},
                   {"latency_max_ms", lat.max},
                   {"events", f.events},
                   {"shed", last.shed},
                   {"scans_lost", last.scans_lost},
                   {"loopd_exit_code", f.daemon_rc},
                   {"loopd_died", f.daemon_died},
                   {"loopd_killed", f.killed},
                   {"plot", f.png},
                   {"windows", jw}};
  tools::print_json_line(j);
}

}  // namespace

int run_bench_soak(int argc, char** argv) {
  CLI::App app("loopd-bench soak: the loopd binary live for N minutes against a looping drive; memory, threads, fds, latency", "loopd-bench soak");
  SoakOptions o;
  add_options(app, o);
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  std::string url;
  if (auto rc = prepare_soak(o, &url)) return *rc;
  const LoopPlan plan = plan_loop(o.drive);
  if (!plan.error.empty()) {
    std::cerr << "loopd-bench soak: " << plan.error << "\n";
    return 1;
  }
  describe_plan(plan, o.stop_s, url);

  // The daemon, then the listener, then the publisher.
  const std::string daemon_log = o.out_dir + "/loopd.log";
  const pid_t pid = start_loopd(o, url, daemon_log);
  if (pid <= 0) return 1;

  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // let loopd subscribe
  const double t0 = mono_s();
  Listener listener(t0);
  std::atomic<bool> stop{false};
  lcm::LCM rx(url);
  if (!rx.good()) {
    std::cerr << "loopd-bench soak: cannot open LCM on " << url << "\n";
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
    return 1;
  }
  rx.subscribe(channels::kLoopEvent, &Listener::on_event, &listener);
  rx.subscribe(channels::kStatus, &Listener::on_status, &listener);
  std::thread rx_thread([&] {
    while (!stop.load()) rx.handleTimeout(100);
  });
  PublishStats pub;
  std::thread pub_thread(publish_loops, url, o.drive, std::cref(plan), o.speed, o.stop_s, &listener, &stop, &pub);

  std::vector<Sample> samples;
  int daemon_rc = -1;
  bool daemon_died = false;
  const double total_s = o.minutes * 60.0;
  const auto take_sample = [&](double t) { samples.push_back(sample_daemon(pid, listener, pub, t)); };
  take_sample(0.0);
  for (double next = o.poll_s; !g_interrupted.load();) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) {
      daemon_died = true;
      daemon_rc = exit_code(status);
      break;
    }
    const double t = mono_s() - t0;
    if (t >= std::min(next, total_s)) {
      take_sample(t);
      if (t >= total_s) break;
      next += o.poll_s;
    }
    if (pub.failed.load()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  const double run_s = mono_s() - t0;
  stop.store(true);
  pub_thread.join();
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // the last decisions and a status

  bool killed = false;
  double term_s = 0;
  if (!daemon_died) {
    const DaemonEnd end = stop_daemon(pid, o.term_timeout_s);
    daemon_rc = end.rc;
    killed = end.killed;
    term_s = end.term_s;
  }
  rx_thread.join();
  if (!pub.error.empty()) std::cerr << "loopd-bench soak: publisher: " << pub.error << "\n";

  // Report.
  const auto latency = listener.latency();
  const auto events = listener.event_times();
  const auto windows = make_windows(samples, events, latency, o.window_min * 60.0, run_s);
  print_windows(windows);
  write_latency(o.out_dir, latency);

  const double warmup_s = std::min(o.warmup_min * 60.0, 0.2 * run_s);
  const RssFit fit = fit_rss(samples, warmup_s);
  std::vector<double> all_ms;
  for (const auto& l : latency) all_ms.push_back(l.ms);
  const tools::Summary lat = tools::summarize(all_ms);
  const Sample first = samples.front(), last = samples.back();
  const Sample* after_warmup = &first_after(samples, warmup_s);
  std::string plot_error;
  const std::string png = write_plot(o.out_dir, samples, &plot_error);

  const SoakFigures f{run_s, windows,   fit,         lat,    p99(all_ms),   events.size(),       first,  last,       png,
                      url,   daemon_rc, daemon_died, killed, *after_warmup, listener.accepted(), term_s, plot_error, daemon_log};
  print_soak_summary(o, f, pub);
  if (o.json) print_soak_json(o, f, pub);
  return daemon_died || killed || daemon_rc != 0 || pub.failed.load() ? 1 : 0;
}
