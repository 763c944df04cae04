// Plane-based four-point congruent sets (Vlaminck 2019, Sec. 4.2, after Aiger 2008):
//  1. coplanar bases are taken on planar clusters of the source, from points on their convex hull (wide bases),
//  2. congruent sets are searched among pairs of points lying on planar clusters of the target, with the affine
//     invariants r1, r2 (Eq. 1), intermediate points e1, e2 (Eq. 2) matched on a k-d tree and a rigid angle check,
//  3. one rigid transform per congruent set (closed-form, 4 correspondences),
//  4. each scored by the largest common point set (LCP) with early termination; the best one wins.
// No random sampling anywhere: the same input gives the same output on any number of threads.
#include "loopd/registration/four_pcs.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <unordered_set>

#include <nanoflann.hpp>

#include "loopd/base/stopwatch.hpp"
#include "loopd/base/angles.hpp"
#include "loopd/registration/radius_grid.hpp"

namespace loopd {
namespace {

constexpr float kHorizontalPlaneNz = 0.85f;  // |n_z| above this: a horizontal plane (ground, roofs)
constexpr double kMinInvariant = 0.08;       // r1, r2 must lie in [kMinInvariant, 1 - kMinInvariant]
constexpr int kScoreBlock = 8;               // candidates fully scored per block against a fixed best (determinism)
constexpr int kCheckEvery = 16;              // early-termination check period [points]

inline double deg2rad(double d) { return d * kPi / 180.0; }

// k-d tree (nanoflann, like base/kdtree.hpp) with the two searches of the LCP, without per-query allocation: "any
// point within delta?" for the LCP test (Sec. 4.2.3; the search stops at the first point inside the ball) and
// nearest-within-radius for the refinement. Coincident intermediate points (Sec. 4.2.2) are found by a RadiusGrid.
class PointTree {
 public:
  explicit PointTree(const std::vector<Eigen::Vector3f>& pts) : adaptor_{&pts}, tree_(3, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {
    if (!pts.empty()) tree_.buildIndex();
  }
  bool any_within(const Eigen::Vector3f& q, float radius_sq) const {
    if (adaptor_.pts->empty()) return false;
    AnyWithin rs{radius_sq, false};
    tree_.findNeighbors(rs, q.data(), nanoflann::SearchParams());
    return rs.found;
  }
  /// Nearest point within sqrt(radius_sq); -1 if none.
  int nearest_within(const Eigen::Vector3f& q, float radius_sq) const {
    if (adaptor_.pts->empty()) return -1;
    NearestWithin rs{radius_sq, -1};
    tree_.findNeighbors(rs, q.data(), nanoflann::SearchParams());
    return rs.index;
  }

 private:
  struct Adaptor {
    const std::vector<Eigen::Vector3f>* pts;
    std::size_t kdtree_get_point_count() const { return pts->size(); }
    float kdtree_get_pt(std::size_t i, std::size_t d) const { return (*pts)[i][static_cast<Eigen::Index>(d)]; }
    template <class B>
    bool kdtree_get_bbox(B&) const {
      return false;
    }
  };
  struct AnyWithin {
    float radius_sq;
    bool found;
    bool full() const { return found; }
    float worstDist() const { return radius_sq; }
    bool addPoint(float dist, std::uint32_t) {
      if (dist < radius_sq) found = true;
      return !found;  // false stops the search
    }
  };
  struct NearestWithin {
    float best_sq;
    int index;
    bool full() const { return true; }
    float worstDist() const { return best_sq; }
    bool addPoint(float dist, std::uint32_t i) {
      if (dist < best_sq) {
        best_sq = dist;
        index = static_cast<int>(i);
      }
      return true;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Adaptor>, Adaptor, 3, std::uint32_t>;
  Adaptor adaptor_;
  Tree tree_;
};

struct Base {
  Eigen::Vector3f p[4];  // a, b, c, d: diagonals ab and cd cross at e
  float r1 = 0, r2 = 0;  // Eq. (1)
  float len1 = 0, len2 = 0;
  float cos_angle = 0;  // between (b - a) and (d - c)
  float tilt = 0;       // [rad] angle of the base plane normal from the vertical axis, folded to [0, pi/2]
  float width = 0;
  int cluster = -1;
  bool horizontal = false;
};

struct PoolPoint {
  Eigen::Vector3f p;
  int cluster;
};

struct Pair {
  int i, j;
  float dist;
};

struct Candidate {
  int q[4];
  Eigen::Isometry3d T;
  float error;  // congruence error [m]: diagonal length mismatch + e1/e2 gap
};

// Coarse pose cell: candidates falling in an already scored cell are near-duplicates (the same wall matched by
// neighbouring points) and are not scored again.
std::int64_t pose_cell(const Eigen::Isometry3d& T, double rot_step, double trans_step) {
  const Eigen::Matrix3d& R = T.linear();
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  const double tilt_x = std::atan2(R(2, 1), R(2, 2)), tilt_y = std::asin(std::max(-1.0, std::min(1.0, -R(2, 0))));
  auto q = [](double v, double step) { return static_cast<std::int64_t>(std::floor(v / step)) & 0x3ff; };
  const Eigen::Vector3d t = T.translation();
  return (q(yaw, rot_step) << 50) | (q(tilt_x, 2.5 * rot_step) << 40) | (q(tilt_y, 2.5 * rot_step) << 30) | (q(t.x(), trans_step) << 20) |
         (q(t.y(), trans_step) << 10) | q(t.z(), trans_step);
}

inline float plane_tilt(const Eigen::Vector4f& plane) { return std::acos(std::min(1.f, std::abs(plane.z()))); }

// Closest points of lines a + t (b - a) and c + s (d - c); false when (nearly) parallel.
bool line_intersection(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c, const Eigen::Vector3f& d, float* t, float* s,
                       float* gap) {
  const Eigen::Vector3f u = b - a, v = d - c, w = a - c;
  const float uu = u.dot(u), uv = u.dot(v), vv = v.dot(v), uw = u.dot(w), vw = v.dot(w);
  const float den = uu * vv - uv * uv;
  if (den <= 1e-6f * uu * vv) return false;
  *t = (uv * vw - vv * uw) / den;
  *s = (uu * vw - uv * uw) / den;
  *gap = ((a + *t * u) - (c + *s * v)).norm();
  return true;
}

// Wide coplanar bases on one planar cluster: for direction pairs (0/90, 30/120, 60/150 deg) in the plane, the hull
// points extreme along each direction form the two diagonals; they cross inside the hull (Sec. 4.2.1: "points close
// to the convex hull").
void bases_for_cluster(const Cluster& cl, int cluster_index, const FourPcsConfig& cfg, std::vector<Base>* out) {
  const auto& h = cl.hull;
  if (h.size() < 4) return;
  const Eigen::Vector3f n = cl.plane.head<3>();
  Eigen::Vector3f u = (h[0] - cl.centroid);
  // In-plane axes: u along the major extent (farthest hull point from the centroid), v = n x u.
  float best = -1;
  for (const auto& p : h) {
    const Eigen::Vector3f d = p - cl.centroid - n * n.dot(p - cl.centroid);
    if (d.squaredNorm() > best) {
      best = d.squaredNorm();
      u = d;
    }
  }
  if (best <= 0) return;
  u.normalize();
  const Eigen::Vector3f v = n.cross(u).normalized();
  for (int k = 0; k < 3; ++k) {
    const double ang = deg2rad(30.0 * k);
    const Eigen::Vector3f d1 = static_cast<float>(std::cos(ang)) * u + static_cast<float>(std::sin(ang)) * v;
    const Eigen::Vector3f d2 = n.cross(d1);
    int imin1 = 0, imax1 = 0, imin2 = 0, imax2 = 0;
    for (int i = 1; i < static_cast<int>(h.size()); ++i) {
      const auto& p = h[static_cast<std::size_t>(i)];
      if (p.dot(d1) < h[static_cast<std::size_t>(imin1)].dot(d1)) imin1 = i;
      if (p.dot(d1) > h[static_cast<std::size_t>(imax1)].dot(d1)) imax1 = i;
      if (p.dot(d2) < h[static_cast<std::size_t>(imin2)].dot(d2)) imin2 = i;
      if (p.dot(d2) > h[static_cast<std::size_t>(imax2)].dot(d2)) imax2 = i;
    }
    const int ids[4] = {imin1, imax1, imin2, imax2};
    bool distinct = true;
    for (int x = 0; x < 4; ++x)
      for (int y = x + 1; y < 4; ++y) distinct = distinct && ids[x] != ids[y];
    if (!distinct) continue;
    Base b;
    for (int x = 0; x < 4; ++x) b.p[x] = h[static_cast<std::size_t>(ids[x])];
    b.len1 = (b.p[1] - b.p[0]).norm();
    b.len2 = (b.p[3] - b.p[2]).norm();
    b.width = std::min(b.len1, b.len2);
    if (b.width < cfg.min_base_width) continue;
    float t = 0, s = 0, gap = 0;
    if (!line_intersection(b.p[0], b.p[1], b.p[2], b.p[3], &t, &s, &gap)) continue;
    if (t < kMinInvariant || t > 1 - kMinInvariant || s < kMinInvariant || s > 1 - kMinInvariant) continue;
    if (gap > cfg.coplanar_tolerance) continue;
    b.r1 = t;
    b.r2 = s;
    b.cos_angle = (b.p[1] - b.p[0]).normalized().dot((b.p[3] - b.p[2]).normalized());
    b.tilt = plane_tilt(cl.plane);
    b.horizontal = std::abs(cl.plane.z()) > kHorizontalPlaneNz;
    b.cluster = cluster_index;
    bool duplicate = false;
    for (const auto& o : *out)
      if (o.cluster == cluster_index &&
          (o.p[0] - b.p[0]).norm() + (o.p[1] - b.p[1]).norm() + (o.p[2] - b.p[2]).norm() + (o.p[3] - b.p[3]).norm() < 0.5f)
        duplicate = true;
    if (!duplicate) out->push_back(b);
  }
}

// Bases ranked by width and spread over planes: round-robin over planes (each plane's widest first), non-horizontal
// planes before horizontal ones. A horizontal plane such as the ground is range-limited and flat: its bases match
// at any yaw, so they are only a last resort.
std::vector<Base> select_bases(const Segmentation& seg, const FourPcsConfig& cfg) {
  std::vector<std::vector<Base>> per_plane;
  for (int i = 0; i < static_cast<int>(seg.clusters.size()); ++i) {
    const auto& cl = seg.clusters[static_cast<std::size_t>(i)];
    if (!cl.planar) continue;
    std::vector<Base> b;
    bases_for_cluster(cl, i, cfg, &b);
    if (b.empty()) continue;
    std::stable_sort(b.begin(), b.end(), [](const Base& x, const Base& y) { return x.width > y.width; });
    per_plane.push_back(std::move(b));
  }
  std::stable_sort(per_plane.begin(), per_plane.end(), [](const std::vector<Base>& x, const std::vector<Base>& y) {
    if (x[0].horizontal != y[0].horizontal) return !x[0].horizontal;
    return x[0].width > y[0].width;
  });
  std::vector<Base> out;
  for (int pass = 0; pass < 2; ++pass) {  // pass 0: non-horizontal planes, pass 1: horizontal ones
    for (std::size_t round = 0;; ++round) {
      bool any = false;
      for (const auto& b : per_plane) {
        if (b[0].horizontal != (pass == 1) || round >= b.size()) continue;
        any = true;
        if (static_cast<int>(out.size()) < cfg.max_bases) out.push_back(b[round]);
      }
      if (!any || static_cast<int>(out.size()) >= cfg.max_bases) break;
    }
  }
  return out;
}

// Closed-form rigid transform (Umeyama 1991, no scale) mapping src[i] onto dst[i].
Eigen::Isometry3d rigid_from_correspondences(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& dst) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix() = Eigen::umeyama(src, dst, false);
  return T;
}

// The source points scored for the LCP: a deterministic, spatially scrambled subsample (so that early termination
// sees a representative prefix), without the ground plane when asked.
std::vector<Eigen::Vector3f> lcp_sample(const std::vector<Eigen::Vector3f>& pts, const Segmentation& seg, const FourPcsConfig& cfg) {
  const Cluster* ground = nullptr;
  if (cfg.lcp_exclude_ground) {
    for (const auto& cl : seg.clusters)
      if (cl.planar && std::abs(cl.plane.z()) > kHorizontalPlaneNz && cl.centroid.z() < 0 &&
          (ground == nullptr || cl.num_points > ground->num_points))
        ground = &cl;
  }
  std::vector<const Eigen::Vector3f*> keep;
  keep.reserve(pts.size());
  for (const auto& p : pts) {
    if (ground != nullptr && std::abs(ground->plane.head<3>().dot(p) + ground->plane.w()) < 0.25f) continue;
    keep.push_back(&p);
  }
  if (keep.size() < 16) {  // nothing but ground: score everything
    keep.clear();
    for (const auto& p : pts) keep.push_back(&p);
  }
  const std::size_t n = keep.size();
  const std::size_t m = cfg.lcp_sample_points > 0 ? std::min(n, static_cast<std::size_t>(cfg.lcp_sample_points)) : n;
  // Stride with a step coprime to n: a fixed permutation that visits the cloud in a scattered order.
  std::size_t step = static_cast<std::size_t>(static_cast<double>(n) * 0.6180339887) | 1u;
  auto gcd = [](std::size_t a, std::size_t b) {
    while (b != 0) {
      const std::size_t t = a % b;
      a = b;
      b = t;
    }
    return a;
  };
  while (n > 1 && gcd(step, n) != 1) ++step;
  std::vector<Eigen::Vector3f> out;
  out.reserve(m);
  std::size_t idx = 0;
  for (std::size_t k = 0; k < m; ++k) {
    out.push_back(*keep[idx]);
    idx = (idx + step) % n;
  }
  return out;
}

// LCP count of T over sample[begin, end) added to `count`; returns -1 as soon as `must_reach` cannot be reached any
// more (early termination, Sec. 4.2.3).
int lcp_count(const Eigen::Isometry3d& T, const std::vector<Eigen::Vector3f>& sample, int begin, int end, int count, const PointTree& tree,
              float delta_sq, int must_reach) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  for (int k = begin; k < end; ++k) {
    if (tree.any_within(R * sample[static_cast<std::size_t>(k)] + t, delta_sq)) ++count;
    if ((k + 1 - begin) % kCheckEvery == 0 && count + (end - k - 1) < must_reach) return -1;
  }
  return count < must_reach ? -1 : count;
}

// ---- Step 2 inputs (Sec. 4.2.2): target points and the coplanar pairs among them ----

// The target side of the congruent-set search: pool points on planar clusters and the pairs among them.
struct TargetPairs {
  const Segmentation& seg;
  std::vector<PoolPoint> pool;
  std::vector<Pair> pairs;  // sorted by length (ties: by indices)
};

// Target points that may form congruent sets: hulls (and downsampled members) of planar clusters (Sec. 4.2.2).
std::vector<PoolPoint> target_pool(const Segmentation& target_seg, const FourPcsConfig& cfg) {
  std::vector<PoolPoint> pool;
  for (int ci = 0; ci < static_cast<int>(target_seg.clusters.size()); ++ci) {
    const auto& cl = target_seg.clusters[static_cast<std::size_t>(ci)];
    if (!cl.planar) continue;
    for (const auto& p : cl.hull) pool.push_back({p, ci});
    if (cfg.use_cluster_points)
      for (const auto& p : cl.points) pool.push_back({p, ci});
  }
  return pool;
}

constexpr float kLenBin = 0.1f;  // [m] bin of the wanted-length table

// Only lengths some base diagonal can use are kept: a table over kLenBin length bins.
std::vector<char> wanted_lengths(const std::vector<Base>& bases, const FourPcsConfig& cfg) {
  std::vector<char> wanted;
  for (const Base& b : bases)
    for (float len : {b.len1, b.len2}) {
      const int lo = std::max(0, static_cast<int>((len - static_cast<float>(cfg.pair_distance_tolerance)) / kLenBin) - 1);
      const int hi = static_cast<int>((len + static_cast<float>(cfg.pair_distance_tolerance)) / kLenBin) + 1;
      if (static_cast<int>(wanted.size()) <= hi) wanted.resize(static_cast<std::size_t>(hi + 1), 0);
      for (int k = lo; k <= hi; ++k) wanted[static_cast<std::size_t>(k)] = 1;
    }
  return wanted;
}

// Pairs of pool points lying in one physical plane (same cluster, or clusters of the same plane) with a wanted
// length, sorted by length.
std::vector<Pair> coplanar_pairs(const std::vector<PoolPoint>& pool, const Segmentation& target_seg, const std::vector<char>& wanted,
                                 const FourPcsConfig& cfg) {
  const float cop = static_cast<float>(cfg.coplanar_tolerance);
  const float min_len = static_cast<float>(cfg.min_base_width - cfg.pair_distance_tolerance);
  const float cos_same_plane = static_cast<float>(std::cos(deg2rad(15.0)));
  const float max_len = static_cast<float>(wanted.size()) * kLenBin;
  std::vector<Pair> pairs;
  for (int i = 0; i < static_cast<int>(pool.size()); ++i) {
    const auto& pi = pool[static_cast<std::size_t>(i)];
    const Eigen::Vector4f& Pi = target_seg.clusters[static_cast<std::size_t>(pi.cluster)].plane;
    for (int j = i + 1; j < static_cast<int>(pool.size()); ++j) {
      const auto& pj = pool[static_cast<std::size_t>(j)];
      const float d2 = (pi.p - pj.p).squaredNorm();
      if (d2 < min_len * min_len || d2 >= max_len * max_len) continue;
      const float d = std::sqrt(d2);
      if (!wanted[static_cast<std::size_t>(d / kLenBin)]) continue;
      if (pj.cluster != pi.cluster) {
        const Eigen::Vector4f& Pj = target_seg.clusters[static_cast<std::size_t>(pj.cluster)].plane;
        if (std::abs(Pi.head<3>().dot(Pj.head<3>())) < cos_same_plane) continue;
        if (std::abs(Pi.head<3>().dot(pj.p) + Pi.w()) > cop || std::abs(Pj.head<3>().dot(pi.p) + Pj.w()) > cop) continue;
      }
      pairs.push_back({i, j, d});
    }
  }
  std::sort(pairs.begin(), pairs.end(),
            [](const Pair& a, const Pair& b) { return a.dist < b.dist || (a.dist == b.dist && (a.i < b.i || (a.i == b.i && a.j < b.j))); });
  return pairs;
}

// ---- LCP scoring data and search tolerances ----

// The refinement keeps the ground: it is what pins height, roll and pitch.
std::vector<Eigen::Vector3f> refine_lcp_sample(const std::vector<Eigen::Vector3f>& pts, const Segmentation& seg, const FourPcsConfig& cfg) {
  FourPcsConfig refine_cfg = cfg;
  refine_cfg.lcp_exclude_ground = false;
  return lcp_sample(pts, seg, refine_cfg);
}

// LCP scoring data (Sec. 4.2.3): the scrambled source samples and the target tree. Built in place and never copied
// (the tree refers to the target points).
struct LcpScoring {
  LcpScoring(const std::vector<Eigen::Vector3f>& source_points, const Segmentation& source_seg, const std::vector<Eigen::Vector3f>& target_points_in,
             const FourPcsConfig& cfg)
      : sample(lcp_sample(source_points, source_seg, cfg)),
        refine_sample(refine_lcp_sample(source_points, source_seg, cfg)),
        target_points(target_points_in),
        target_tree(target_points_in),
        delta_sq(static_cast<float>(cfg.delta * cfg.delta)),
        n_sample(static_cast<int>(sample.size())),
        prescreen_n(std::min(cfg.prescreen_points, n_sample)) {}
  LcpScoring(const LcpScoring&) = delete;
  LcpScoring& operator=(const LcpScoring&) = delete;

  std::vector<Eigen::Vector3f> sample;         // scored for the LCP (ground excluded when asked)
  std::vector<Eigen::Vector3f> refine_sample;  // used by the closest-point refinement (ground kept)
  const std::vector<Eigen::Vector3f>& target_points;
  PointTree target_tree;
  float delta_sq;   // [m^2]
  int n_sample;     // sample.size()
  int prescreen_n;  // prescore on sample[0, prescreen_n)
};

// Tolerances of the congruent-set search (Sec. 4.2.2), converted once from the config.
struct SearchTolerances {
  float cop = 0;            // [m] the 4 target points lie this close to the first pair's plane
  double max_tilt = 0;      // [rad] max up-axis change, and max plane tilt difference base/target
  double cos_max_tilt = 0;  // cos(max_tilt)
  float cos_angle_tol = 0;  // [rad] rigid check on the angle between the diagonals (an angle, not a cosine)
  float pair_tol = 0;       // [m] pair length vs diagonal length
  float e_tol = 0;          // [m] coincident intermediate points
  double rot_step = 0;      // [rad] pose cell for de-duplication
  double trans_step = 0;    // [m] pose cell for de-duplication
};

SearchTolerances search_tolerances(const FourPcsConfig& cfg) {
  SearchTolerances tol;
  tol.cop = static_cast<float>(cfg.coplanar_tolerance);
  tol.max_tilt = deg2rad(cfg.max_tilt_deg);
  tol.cos_max_tilt = std::cos(tol.max_tilt);
  tol.cos_angle_tol = static_cast<float>(deg2rad(cfg.max_angle_deviation_deg));
  tol.pair_tol = static_cast<float>(cfg.pair_distance_tolerance);
  tol.e_tol = static_cast<float>(cfg.intermediate_tolerance);
  tol.rot_step = deg2rad(cfg.dedupe_rotation_deg);
  tol.trans_step = cfg.dedupe_translation;
  return tol;
}

// ---- Steps 2-3, per base (Sec. 4.2.2) ----

// The pair-level checks of one base: pairs as long as each diagonal, on target planes whose tilt matches the base's.
struct DiagonalChecks {
  using PairRange = std::pair<std::vector<Pair>::const_iterator, std::vector<Pair>::const_iterator>;

  DiagonalChecks(const Base& base_in, const TargetPairs& target_in, const SearchTolerances& tol_in)
      : base(base_in),
        target(target_in),
        tol(tol_in),
        dz1(base_in.p[1].z() - base_in.p[0].z()),
        dz2(base_in.p[3].z() - base_in.p[2].z()),
        sin_tilt(static_cast<float>(std::sin(std::min(tol_in.max_tilt, kPi / 2)))) {}

  PairRange pairs_of_length(float len) const {
    const auto lo = std::lower_bound(target.pairs.begin(), target.pairs.end(), len - tol.pair_tol, [](const Pair& p, float v) { return p.dist < v; });
    const auto hi = std::upper_bound(target.pairs.begin(), target.pairs.end(), len + tol.pair_tol, [](float v, const Pair& p) { return v < p.dist; });
    return std::make_pair(lo, hi);
  }
  bool tilt_ok(int pool_index) const {
    const auto& cl = target.seg.clusters[static_cast<std::size_t>(target.pool[static_cast<std::size_t>(pool_index)].cluster)];
    return std::abs(plane_tilt(cl.plane) - base.tilt) <= tol.max_tilt;
  }
  // Up-axis check at pair level: a diagonal's height change can differ from the base's only by the allowed tilt.
  bool dz_ok(const Eigen::Vector3f& a, const Eigen::Vector3f& b, float dz_base, float len) const {
    return std::abs((b.z() - a.z()) - dz_base) <= 2.f * sin_tilt * len + tol.pair_tol;
  }

  const Base& base;
  const TargetPairs& target;
  const SearchTolerances& tol;
  float dz1, dz2;  // [m] height change along each base diagonal
  float sin_tilt;
};

// The rigid check of a congruent set against its base: the angle between the diagonals and the four cross
// distances, which together make it exact for 4 points.
struct RigidCheck {
  RigidCheck(const Base& base, const SearchTolerances& tol) {
    const double base_angle = std::acos(std::max(-1.f, std::min(1.f, base.cos_angle)));
    cos_hi = static_cast<float>(std::cos(std::max(0.0, base_angle - tol.cos_angle_tol)));
    cos_lo = static_cast<float>(std::cos(std::min(kPi, base_angle + tol.cos_angle_tol)));
    ac = (base.p[2] - base.p[0]).norm();
    ad = (base.p[3] - base.p[0]).norm();
    bc = (base.p[2] - base.p[1]).norm();
    bd = (base.p[3] - base.p[1]).norm();
    cross_tol = 2.f * tol.pair_tol;
  }
  float cos_hi = 0, cos_lo = 0;          // accepted range of the cosine of the angle between the diagonals
  float ac = 0, ad = 0, bc = 0, bd = 0;  // [m] cross distances of the base
  float cross_tol = 0;                   // [m]
};

// Buffers of the per-base search, reused from base to base.
struct BaseScratch {
  std::vector<Eigen::Vector3f> e2;                // intermediate points of the second diagonal
  std::vector<std::pair<int, int>> e2_pair;       // the oriented pool pair of each e2
  std::vector<int> hits;                          // e2 indices near one e1
  std::vector<std::pair<int, Candidate>> passed;  // the hits that make a congruent set, with their e2 index
  std::vector<Candidate> cands;                   // congruent sets of the base
};

// Intermediate points of the second diagonal, Eq. (2) with r2, both orientations of each pair.
void second_diagonal_points(const DiagonalChecks& chk, BaseScratch* s) {
  const Base& base = chk.base;
  const std::vector<PoolPoint>& pool = chk.target.pool;
  s->e2.clear();
  s->e2_pair.clear();
  const auto r2 = chk.pairs_of_length(base.len2);
  for (auto it = r2.first; it != r2.second; ++it) {
    if (!chk.tilt_ok(it->i)) continue;
    const Eigen::Vector3f& a = pool[static_cast<std::size_t>(it->i)].p;
    const Eigen::Vector3f& b = pool[static_cast<std::size_t>(it->j)].p;
    if (chk.dz_ok(a, b, chk.dz2, base.len2)) {
      s->e2.push_back(a + base.r2 * (b - a));
      s->e2_pair.emplace_back(it->i, it->j);
    }
    if (chk.dz_ok(b, a, chk.dz2, base.len2)) {
      s->e2.push_back(b + base.r2 * (a - b));
      s->e2_pair.emplace_back(it->j, it->i);
    }
  }
}

// Congruent sets whose first diagonal is the oriented pool pair (i, j) of length `dist`: its intermediate point e1
// (Eq. 2 with r1) coincides with an e2, the rigid check holds and the 4 points lie on the pair's plane. Appends to
// s->cands, at most up to max_congruent_sets_per_base.
void congruent_sets_on_pair(int i, int j, float dist, const DiagonalChecks& chk, const RigidCheck& rigid, const RadiusGrid& e2_grid,
                            const FourPcsConfig& cfg, BaseScratch* s) {
  const Base& base = chk.base;
  const std::vector<PoolPoint>& pool = chk.target.pool;
  const float cop = chk.tol.cop;
  const Eigen::Vector3f& a = pool[static_cast<std::size_t>(i)].p;
  const Eigen::Vector3f& b = pool[static_cast<std::size_t>(j)].p;
  if (!chk.dz_ok(a, b, chk.dz1, base.len1)) return;
  const Eigen::Vector3f e1 = a + base.r1 * (b - a);
  s->hits.clear();
  e2_grid.within(e1, &s->hits);
  s->passed.clear();
  const Eigen::Vector3f u = (b - a) / dist;
  const Eigen::Vector4f& plane = chk.target.seg.clusters[static_cast<std::size_t>(pool[static_cast<std::size_t>(i)].cluster)].plane;
  for (int h : s->hits) {
    const int k = s->e2_pair[static_cast<std::size_t>(h)].first, l = s->e2_pair[static_cast<std::size_t>(h)].second;
    if (k == i || k == j || l == i || l == j) continue;
    const Eigen::Vector3f& c = pool[static_cast<std::size_t>(k)].p;
    const Eigen::Vector3f& d = pool[static_cast<std::size_t>(l)].p;
    const Eigen::Vector3f cd = d - c;
    const float cos_t = u.dot(cd) / cd.norm();
    if (cos_t > rigid.cos_hi || cos_t < rigid.cos_lo) continue;  // rigid check on the angle (Sec. 4.2.2)
    if (std::abs((c - a).norm() - rigid.ac) > rigid.cross_tol || std::abs((d - a).norm() - rigid.ad) > rigid.cross_tol ||
        std::abs((c - b).norm() - rigid.bc) > rigid.cross_tol || std::abs((d - b).norm() - rigid.bd) > rigid.cross_tol)
      continue;
    if (std::abs(plane.head<3>().dot(c) + plane.w()) > cop || std::abs(plane.head<3>().dot(d) + plane.w()) > cop) continue;
    const float err = std::abs(dist - base.len1) + std::abs(cd.norm() - base.len2) + (e1 - s->e2[static_cast<std::size_t>(h)]).norm();
    s->passed.push_back({h, Candidate{{i, j, k, l}, Eigen::Isometry3d::Identity(), err}});
  }
  // In the order of the second diagonal's points (the cap below keeps the same ones whatever the search's order).
  std::sort(s->passed.begin(), s->passed.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  for (const auto& hit : s->passed) {
    s->cands.push_back(hit.second);
    if (static_cast<int>(s->cands.size()) >= cfg.max_congruent_sets_per_base) return;
  }
}

// Intermediate points of the first diagonal with r1; coincident e1/e2 + rigid check = congruent set. Pairs in length
// order, both orientations, until max_congruent_sets_per_base.
void congruent_sets_of_base(const DiagonalChecks& chk, const FourPcsConfig& cfg, BaseScratch* s) {
  const RadiusGrid e2_grid(s->e2, chk.tol.e_tol);
  s->cands.clear();
  const auto r1 = chk.pairs_of_length(chk.base.len1);
  const RigidCheck rigid(chk.base, chk.tol);
  for (auto it = r1.first; it != r1.second && static_cast<int>(s->cands.size()) < cfg.max_congruent_sets_per_base; ++it) {
    if (!chk.tilt_ok(it->i)) continue;
    for (int orient = 0; orient < 2; ++orient) {
      const int i = orient == 0 ? it->i : it->j, j = orient == 0 ? it->j : it->i;
      congruent_sets_on_pair(i, j, it->dist, chk, rigid, e2_grid, cfg, s);
      if (static_cast<int>(s->cands.size()) >= cfg.max_congruent_sets_per_base) break;
    }
  }
}

// Best-congruent first, then near-duplicate poses dropped, then the cap (all deterministic). The transform (step 3:
// closed form on the 4 correspondences) is computed only for the candidates visited here.
void keep_distinct_poses(const Base& base, const std::vector<PoolPoint>& pool, const SearchTolerances& tol, const FourPcsConfig& cfg,
                         std::vector<Candidate>* cands, std::unordered_set<std::int64_t>* seen_cells) {
  std::stable_sort(cands->begin(), cands->end(), [](const Candidate& x, const Candidate& y) { return x.error < y.error; });
  Eigen::Matrix3Xd src(3, 4), dst(3, 4);
  for (int x = 0; x < 4; ++x) src.col(x) = base.p[x].cast<double>();
  std::size_t w = 0;
  for (std::size_t ci = 0; ci < cands->size() && static_cast<int>(w) < cfg.max_scored_per_base; ++ci) {
    Candidate& cand = (*cands)[ci];
    for (int x = 0; x < 4; ++x) dst.col(x) = pool[static_cast<std::size_t>(cand.q[x])].p.cast<double>();
    cand.T = rigid_from_correspondences(src, dst);
    if (cand.T.linear().col(2).z() < tol.cos_max_tilt) continue;  // the up axis stays up (ground vehicles)
    if (seen_cells->insert(pose_cell(cand.T, tol.rot_step, tol.trans_step)).second) (*cands)[w++] = cand;
  }
  cands->resize(w);
}

// Congruent sets kept over all bases tried, with their prescores.
struct CongruentSets {
  std::vector<Candidate> all;
  std::vector<int> pre;  // prescore per candidate
  int best_pre = 0;
  std::unordered_set<std::int64_t> seen_cells;  // pose cells already kept
};

// Prescore (LCP on the first sample points, Sec. 4.2.3 a) of a base's candidates right away, so that a base giving a
// clear winner ends the search.
void prescore(const std::vector<Candidate>& cands, const LcpScoring& lcp, const FourPcsConfig& cfg, CongruentSets* sets) {
  std::vector<Candidate>& all = sets->all;
  std::vector<int>& pre = sets->pre;
  const std::size_t first = all.size();
  all.insert(all.end(), cands.begin(), cands.end());
  pre.resize(all.size(), 0);
  const int n_new = static_cast<int>(cands.size());
#pragma omp parallel for num_threads(cfg.num_threads) schedule(dynamic, 8)
  for (int ci = 0; ci < n_new; ++ci)
    pre[first + static_cast<std::size_t>(ci)] =
        lcp_count(all[first + static_cast<std::size_t>(ci)].T, lcp.sample, 0, lcp.prescreen_n, 0, lcp.target_tree, lcp.delta_sq, 0);
  for (std::size_t ci = first; ci < all.size(); ++ci) sets->best_pre = std::max(sets->best_pre, pre[ci]);
}

// Steps 2-3 for the bases in rank order: congruent sets, one transform each, prescored; no further bases once a
// prescore fraction reaches early_stop_prescore.
CongruentSets collect_congruent_sets(const std::vector<Base>& bases, const TargetPairs& target, const LcpScoring& lcp, const SearchTolerances& tol,
                                     const FourPcsConfig& cfg, int* bases_tried) {
  CongruentSets sets;
  BaseScratch scratch;
  for (const Base& base : bases) {
    ++*bases_tried;
    const DiagonalChecks chk(base, target, tol);
    second_diagonal_points(chk, &scratch);
    if (scratch.e2.empty()) continue;
    congruent_sets_of_base(chk, cfg, &scratch);
    keep_distinct_poses(base, target.pool, tol, cfg, &scratch.cands, &sets.seen_cells);
    prescore(scratch.cands, lcp, cfg, &sets);
    if (sets.best_pre >= cfg.early_stop_prescore * lcp.prescreen_n) break;
  }
  return sets;
}

// ---- Step 4 (Sec. 4.2.3 b, c): full LCP and refinement ----

// The full LCP of the best prescored candidates and the leaders among them.
struct FullScores {
  std::vector<int> order;    // candidate indices, highest prescore first, at most max_full_scores
  std::vector<int> full;     // full LCP per entry of order; -1: terminated early
  std::vector<int> leaders;  // entries of order, highest full LCP first, at most refine_candidates
};

// Candidate indices by prescore (stable: ties keep candidate order), at most max_full_scores.
std::vector<int> best_prescored(const CongruentSets& sets, const FourPcsConfig& cfg) {
  const std::vector<int>& pre = sets.pre;
  const int n_all = static_cast<int>(sets.all.size());
  std::vector<int> order(sets.all.size());
  for (int ci = 0; ci < n_all; ++ci) order[static_cast<std::size_t>(ci)] = ci;
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return pre[static_cast<std::size_t>(x)] > pre[static_cast<std::size_t>(y)]; });
  order.resize(std::min(order.size(), static_cast<std::size_t>(cfg.max_full_scores)));
  return order;
}

// Full LCP in blocks of kScoreBlock, each with early termination against the best count fixed before the block.
FullScores full_lcp_scores(const CongruentSets& sets, const LcpScoring& lcp, const FourPcsConfig& cfg) {
  FullScores s;
  s.order = best_prescored(sets, cfg);
  const std::vector<int>& order = s.order;
  std::vector<int>& full = s.full;
  full.assign(order.size(), -1);
  int best_count = 0;
  for (std::size_t b0 = 0; b0 < order.size(); b0 += kScoreBlock) {
    const std::size_t b1 = std::min(order.size(), b0 + kScoreBlock);
    const int must_reach = best_count;
#pragma omp parallel for num_threads(cfg.num_threads) schedule(dynamic, 1)
    for (std::ptrdiff_t oi = static_cast<std::ptrdiff_t>(b0); oi < static_cast<std::ptrdiff_t>(b1); ++oi) {
      const int ci = order[static_cast<std::size_t>(oi)];
      full[static_cast<std::size_t>(oi)] = lcp_count(sets.all[static_cast<std::size_t>(ci)].T, lcp.sample, lcp.prescreen_n, lcp.n_sample,
                                                     sets.pre[static_cast<std::size_t>(ci)], lcp.target_tree, lcp.delta_sq, must_reach);
    }
    for (std::size_t oi = b0; oi < b1; ++oi) best_count = std::max(best_count, full[oi]);
  }
  for (std::size_t oi = 0; oi < order.size(); ++oi)
    if (full[oi] >= 0) s.leaders.push_back(static_cast<int>(oi));
  std::stable_sort(s.leaders.begin(), s.leaders.end(),
                   [&](int x, int y) { return full[static_cast<std::size_t>(x)] > full[static_cast<std::size_t>(y)]; });
  s.leaders.resize(std::min(s.leaders.size(), static_cast<std::size_t>(std::max(1, cfg.refine_candidates))));
  return s;
}

// Closest-point refinement of a pose: refine_iterations rigid fits to the nearest target points within delta of the
// refinement sample; stops when fewer than 8 points correspond.
Eigen::Isometry3d closest_point_refinement(const Eigen::Isometry3d& T_start, const LcpScoring& lcp, const FourPcsConfig& cfg) {
  Eigen::Isometry3d T = T_start;
  for (int it = 0; it < cfg.refine_iterations; ++it) {
    std::vector<Eigen::Vector3d> s_in, t_in;
    for (const auto& p : lcp.refine_sample) {
      const Eigen::Vector3f q = (T * p.cast<double>()).cast<float>();
      const int idx = lcp.target_tree.nearest_within(q, lcp.delta_sq);
      if (idx >= 0) {
        s_in.push_back(p.cast<double>());
        t_in.push_back(lcp.target_points[static_cast<std::size_t>(idx)].cast<double>());
      }
    }
    if (s_in.size() < 8) break;
    Eigen::Matrix3Xd S(3, static_cast<Eigen::Index>(s_in.size())), D(3, static_cast<Eigen::Index>(t_in.size()));
    for (std::size_t k = 0; k < s_in.size(); ++k) {
      S.col(static_cast<Eigen::Index>(k)) = s_in[k];
      D.col(static_cast<Eigen::Index>(k)) = t_in[k];
    }
    T = rigid_from_correspondences(S, D);
  }
  return T;
}

struct ScoredPose {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  int count = 0;  // LCP count on the sample
};

// Closest-point refinement on LCP inliers; a refined pose replaces the raw one only if its LCP is not lower. The
// highest LCP wins (ties: the first leader).
ScoredPose refine_leaders(const CongruentSets& sets, const FullScores& s, const LcpScoring& lcp, const FourPcsConfig& cfg) {
  std::vector<Eigen::Isometry3d> refined_T(s.leaders.size());
  std::vector<int> refined_count(s.leaders.size(), 0);
#pragma omp parallel for num_threads(cfg.num_threads) schedule(dynamic, 1)
  for (int li = 0; li < static_cast<int>(s.leaders.size()); ++li) {
    const std::size_t oi = static_cast<std::size_t>(s.leaders[static_cast<std::size_t>(li)]);
    const Eigen::Isometry3d& T_raw = sets.all[static_cast<std::size_t>(s.order[oi])].T;
    const Eigen::Isometry3d T = closest_point_refinement(T_raw, lcp, cfg);
    const int c = lcp_count(T, lcp.sample, 0, lcp.n_sample, 0, lcp.target_tree, lcp.delta_sq, 0);
    const bool better = c >= s.full[oi];
    refined_T[static_cast<std::size_t>(li)] = better ? T : T_raw;
    refined_count[static_cast<std::size_t>(li)] = better ? c : s.full[oi];
  }
  ScoredPose best;
  best.T = refined_T[0];
  best.count = refined_count[0];
  for (std::size_t li = 1; li < s.leaders.size(); ++li)
    if (refined_count[li] > best.count) {
      best.count = refined_count[li];
      best.T = refined_T[li];
    }
  return best;
}

}  // namespace

std::optional<std::string> FourPcsConfig::validate() const {
  if (delta <= 0) return "delta must be > 0";
  if (max_bases < 1) return "max_bases must be >= 1";
  if (min_base_width <= 0) return "min_base_width must be > 0";
  if (pair_distance_tolerance <= 0) return "pair_distance_tolerance must be > 0";
  if (intermediate_tolerance <= 0) return "intermediate_tolerance must be > 0";
  if (max_angle_deviation_deg <= 0 || max_angle_deviation_deg > 90) return "max_angle_deviation_deg must be in (0, 90]";
  if (coplanar_tolerance <= 0) return "coplanar_tolerance must be > 0";
  if (max_tilt_deg <= 0) return "max_tilt_deg must be > 0";
  if (max_congruent_sets_per_base < 1) return "max_congruent_sets_per_base must be >= 1";
  if (lcp_sample_points < 0) return "lcp_sample_points must be >= 0";
  if (prescreen_points < 1) return "prescreen_points must be >= 1";
  if (max_full_scores < 1) return "max_full_scores must be >= 1";
  if (refine_candidates < 1) return "refine_candidates must be >= 1";
  if (refine_iterations < 0) return "refine_iterations must be >= 0";
  if (num_threads < 1) return "num_threads must be >= 1";
  if (max_scored_per_base < 1) return "max_scored_per_base must be >= 1";
  if (dedupe_rotation_deg <= 0 || dedupe_translation <= 0) return "dedupe_rotation_deg and dedupe_translation must be > 0";
  return std::nullopt;
}

FourPcsResult align_four_pcs(const std::vector<Eigen::Vector3f>& source_points, const Segmentation& source_seg,
                             const std::vector<Eigen::Vector3f>& target_points, const Segmentation& target_seg, const FourPcsConfig& cfg) {
  Stopwatch sw;
  FourPcsResult res;
  auto fail = [&](std::string reason) {
    res.success = false;
    res.reason = std::move(reason);
    res.ms = sw.ms();
    return res;
  };
  if (auto err = cfg.validate()) return fail("invalid FourPcsConfig: " + *err);
  if (source_points.size() < 4 || target_points.size() < 4) return fail("fewer than 4 points in source or target");
  if (source_seg.num_planar() == 0) return fail("no planar cluster in the source: no coplanar base");
  if (target_seg.num_planar() == 0) return fail("no planar cluster in the target: no congruent set possible");

  // 1. Coplanar bases on detected planes (Sec. 4.2.1).
  const std::vector<Base> bases = select_bases(source_seg, cfg);
  if (bases.empty()) return fail("no coplanar base: planar hulls too narrow or collinear (min_base_width)");

  // Target points that may form congruent sets and the pairs among them a base diagonal can use (Sec. 4.2.2).
  TargetPairs target{target_seg, target_pool(target_seg, cfg), {}};
  target.pairs = coplanar_pairs(target.pool, target_seg, wanted_lengths(bases, cfg), cfg);
  if (target.pairs.empty()) return fail("no pair of target plane points as long as a base diagonal");

  // LCP scoring data (Sec. 4.2.3).
  const LcpScoring lcp(source_points, source_seg, target_points, cfg);

  // 2.-3. Congruent sets per base and one rigid transform each, prescored as they come (Sec. 4.2.2, 4.2.3 a).
  const SearchTolerances tol = search_tolerances(cfg);
  const CongruentSets sets = collect_congruent_sets(bases, target, lcp, tol, cfg, &res.bases_tried);
  res.congruent_sets = static_cast<int>(sets.all.size());
  if (sets.all.empty()) return fail("no congruent set found for any of " + std::to_string(res.bases_tried) + " bases");

  // 4. LCP of every congruent set's transform (Sec. 4.2.3), in three deterministic steps (the same on any number of
  // threads, as each candidate's score depends only on the candidate and on bests fixed before its block):
  //  a) a prescore on the first points of the scrambled sample (done per base above),
  //  b) the full LCP of the best prescored ones, with early termination against the best so far,
  //  c) a closest-point refinement of the leaders; the highest LCP wins (ties: lowest index).
  const FullScores scores = full_lcp_scores(sets, lcp, cfg);
  const ScoredPose best = refine_leaders(sets, scores, lcp, cfg);
  res.success = true;
  res.T_target_source = best.T;
  res.lcp_points = lcp.n_sample;
  res.lcp_fraction = lcp.n_sample > 0 ? static_cast<double>(best.count) / lcp.n_sample : 0.0;
  res.ms = sw.ms();
  return res;
}

}  // namespace loopd
