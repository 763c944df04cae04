#include "loopd/sim/route.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace loopd {
namespace {

struct Waypoint {
  int i, j;
  int visit;         ///< visit label of the edge that leaves this waypoint
  bool lane_offset;  ///< the first half of the edge leaving this waypoint is driven with the lane offset
};

/// One lap of the route (cyclic: the last edge returns to the first waypoint).
std::vector<Waypoint> route_waypoints(const std::string& route) {
  std::vector<Waypoint> w;
  auto add = [&](int i, int j, int v, bool off = false) { w.push_back({i, j, v, off}); };
  if (route == "mine") {
    // make_mine's junctions (i 0..3, j 0..2), 60-100 m apart; no U-turns (every visit leaves (0,0) east and comes back
    // from the north). Visit 0: the cell (0..1, 0..1) counter-clockwise. Visit 1: the long loop (0..2, 0..1), its
    // first and last two roadways revisited in the same direction, (1,0) crossed straight. Visit 2: the cell again.
    const std::vector<std::pair<int, int>> cell = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    const std::vector<std::pair<int, int>> long_loop = {{0, 0}, {1, 0}, {2, 0}, {2, 1}, {1, 1}, {0, 1}};
    for (const auto& [i, j] : cell) add(i, j, 0);
    for (const auto& [i, j] : long_loop) add(i, j, 1);
    for (const auto& [i, j] : cell) add(i, j, 2);
    return w;
  }
  if (route == "block" || route == "ring") {
    // Three rounds, counter-clockwise. block: block (0..1, 0..1), the third round starting with the lane offset.
    // ring: the streets two blocks in from the town's edges (-2..4, -2..4; make_town's nodes are -3..5), ~1.5 km a
    // round with buildings on both sides, first revisited after a whole round.
    const int lo = route == "ring" ? -2 : 0, hi = route == "ring" ? 4 : 1;
    for (int v = 0; v < 3; ++v) {
      add(lo, lo, v, route == "block" && v == 2);
      add(hi, lo, v);
      add(hi, hi, v);
      add(lo, hi, v);
    }
    return w;
  }
  // Visit 0: short loop around block (0..1, 0..1), counter-clockwise.
  add(0, 0, 0);
  add(1, 0, 0);
  add(1, 1, 0);
  add(0, 1, 0);
  // Visit 1: long loop around (0..2, 0..2), counter-clockwise: (0,0)->(1,0) again in the same direction (first half
  // 3 m to the left = lane offset), (0,1)->(0,0) again in the same direction.
  add(0, 0, 1, true);
  add(1, 0, 1);
  add(2, 0, 1);
  add(2, 1, 1);
  add(2, 2, 1);
  add(1, 2, 1);
  add(0, 2, 1);
  add(0, 1, 1);
  // Visit 2: turn around through (0,-1), (1,-1), then block (0..1, 0..1) clockwise (opposite direction), back via (1,-1).
  add(0, 0, 2);
  add(0, -1, 2);
  add(1, -1, 2);
  add(1, 0, 2);
  add(0, 0, 2);
  add(0, 1, 2);
  add(1, 1, 2);
  add(1, 0, 2);
  add(1, -1, 2);
  add(0, -1, 2);
  return w;
}

/// The lap in the opposite direction from the same first waypoint: edge w[k] -> w[k-1] gets the label of the edge
/// w[k-1] -> w[k] it reverses, counted from the lap's other end (2 - label: labels still count up along the lap); no
/// lane offset.
std::vector<Waypoint> reversed_waypoints(const std::vector<Waypoint>& w) {
  const std::size_t K = w.size();
  std::vector<Waypoint> r(K);
  for (std::size_t m = 0; m < K; ++m) {
    r[m] = w[(K - m) % K];
    r[m].visit = kRouteVisitsPerLap - 1 - w[(2 * K - m - 1) % K].visit;
    r[m].lane_offset = false;
  }
  return r;
}

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

/// A centre-line sample with its visit label and lateral offset.
struct CentreSample {
  Eigen::Vector2d c;
  int visit;
  double lateral;
};

/// Centre-line samples of one lap through the waypoints: straight edges between rounded corners.
std::vector<CentreSample> centre_line(const Town& town, const DriveConfig& c, const std::vector<Waypoint>& w) {
  const int K = static_cast<int>(w.size());
  std::vector<Eigen::Vector2d> P(static_cast<std::size_t>(K));
  for (int k = 0; k < K; ++k) P[static_cast<std::size_t>(k)] = town.node(w[static_cast<std::size_t>(k)].i, w[static_cast<std::size_t>(k)].j);
  auto at = [&](int k) -> const Eigen::Vector2d& { return P[static_cast<std::size_t>(((k % K) + K) % K)]; };
  const double R = c.corner_radius;
  // Corner entry/exit points.
  std::vector<Eigen::Vector2d> A(static_cast<std::size_t>(K)), B(static_cast<std::size_t>(K));
  std::vector<bool> turn(static_cast<std::size_t>(K));
  for (int k = 0; k < K; ++k) {
    const Eigen::Vector2d u = (at(k) - at(k - 1)).normalized(), v = (at(k + 1) - at(k)).normalized();
    turn[static_cast<std::size_t>(k)] = u.dot(v) < 0.99;
    A[static_cast<std::size_t>(k)] = turn[static_cast<std::size_t>(k)] ? Eigen::Vector2d(at(k) - u * R) : at(k);
    B[static_cast<std::size_t>(k)] = turn[static_cast<std::size_t>(k)] ? Eigen::Vector2d(at(k) + v * R) : at(k);
  }
  std::vector<CentreSample> raw;
  const double ds = 0.05;
  for (int k = 0; k < K; ++k) {
    const Waypoint& wp = w[static_cast<std::size_t>(k)];
    const Eigen::Vector2d s0 = B[static_cast<std::size_t>(k)], s1 = A[static_cast<std::size_t>((k + 1) % K)];
    const double L = (s1 - s0).norm();
    const int n = std::max(1, static_cast<int>(L / ds));
    for (int q = 0; q < n; ++q) {
      const double a = static_cast<double>(q) / n;
      const double along = a * L;
      double lateral = c.lane_lateral;
      if (wp.lane_offset) {
        // Ramp into the offset lane over 10 m, hold to mid-edge, ramp back over 15 m.
        const double up = smoothstep(along / 10.0), down = 1.0 - smoothstep((along - 0.5 * L) / 15.0);
        lateral += c.lane_offset * std::min(up, down);
      }
      raw.push_back({s0 + a * (s1 - s0), wp.visit, lateral});
    }
    const int kn = (k + 1) % K;
    if (turn[static_cast<std::size_t>(kn)]) {
      const Eigen::Vector2d a0 = A[static_cast<std::size_t>(kn)], p = at(kn), b0 = B[static_cast<std::size_t>(kn)];
      const int m = std::max(4, static_cast<int>(1.6 * R / ds));
      for (int q = 0; q < m; ++q) {
        const double t = static_cast<double>(q) / m;
        const Eigen::Vector2d cq = (1 - t) * (1 - t) * a0 + 2 * t * (1 - t) * p + t * t * b0;  // quadratic Bezier corner
        raw.push_back({cq, wp.visit, c.lane_lateral});
      }
    }
  }
  return raw;
}

}  // namespace

bool is_route_name(const std::string& route) { return route == "town" || route == "block" || route == "ring" || route == "mine"; }

std::vector<DrivePathPoint> build_route_path(const Town& town, const DriveConfig& config, bool reversed) {
  const auto forward = route_waypoints(config.route);
  const std::vector<CentreSample> raw = centre_line(town, config, reversed ? reversed_waypoints(forward) : forward);
  // Offset along the left normal of the centre line, then arc length.
  const std::size_t N = raw.size();
  std::vector<DrivePathPoint> out(N);
  for (std::size_t q = 0; q < N; ++q) {
    const Eigen::Vector2d d = raw[(q + 1) % N].c - raw[(q + N - 1) % N].c;
    const Eigen::Vector2d t = d.norm() > 1e-9 ? Eigen::Vector2d(d.normalized()) : Eigen::Vector2d(1, 0);
    const Eigen::Vector2d left(-t.y(), t.x());
    out[q].p = raw[q].c + raw[q].lateral * left;
    out[q].visit = raw[q].visit;
    out[q].s = q == 0 ? 0.0 : out[q - 1].s + (out[q].p - out[q - 1].p).norm();
  }
  return out;
}

}  // namespace loopd
