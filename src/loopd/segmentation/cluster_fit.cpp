// Per-cluster fit (Vlaminck 2019, Sec. 4.2.1): PCA of the members, the plane test, and for planar clusters the 2D
// convex hull in the plane, which picks wide coplanar 4PCS bases; the members are kept voxel-downsampled.
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdint>

#include "loopd/base/voxel_grid.hpp"
#include "loopd/segmentation/segmentation_internal.hpp"

namespace loopd::detail {
namespace {

/// Nothing more per voxel than VoxelGrid's sum and count.
struct NoPayload {};

// Voxel centroids of the members, in key order (VoxelGrid: the same grid as the scan's downsampling), at most `cap`
// of them by an even stride.
std::vector<Eigen::Vector3f> downsample_members(const std::vector<Eigen::Vector3f>& pts, double voxel, int cap) {
  VoxelGrid<NoPayload> grid(voxel, pts.size() / 4 + 1);
  for (const auto& p : pts) grid.add(p);
  const auto voxels = std::move(grid).sorted_voxels();
  std::vector<Eigen::Vector3f> out;
  const std::size_t m = voxels.size();
  const std::size_t keep = std::min(m, static_cast<std::size_t>(cap));
  out.reserve(keep);
  for (std::size_t j = 0; j < keep; ++j) {
    const std::size_t i = keep == m ? j : (j * m) / keep;  // even stride over the sorted voxels
    out.push_back(voxels[i].centroid());
  }
  return out;
}

double cross2(const Eigen::Vector2f& o, const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
  return static_cast<double>(a.x() - o.x()) * (b.y() - o.y()) - static_cast<double>(a.y() - o.y()) * (b.x() - o.x());
}

// Andrew's monotone chain; returns member indices of the hull, counter-clockwise.
std::vector<int> convex_hull_2d(const std::vector<Eigen::Vector2f>& p) {
  const int n = static_cast<int>(p.size());
  std::vector<int> idx(to_index(n));
  for (int i = 0; i < n; ++i) idx[to_index(i)] = i;
  std::sort(idx.begin(), idx.end(), [&](int a, int b) {
    const auto& pa = p[to_index(a)];
    const auto& pb = p[to_index(b)];
    return pa.x() < pb.x() || (pa.x() == pb.x() && (pa.y() < pb.y() || (pa.y() == pb.y() && a < b)));
  });
  if (n < 3) return idx;
  std::vector<int> h(to_index(2 * n));
  // Point of hull slot j and of sorted position i.
  auto hull_pt = [&](int j) -> const Eigen::Vector2f& { return p[to_index(h[to_index(j)])]; };
  auto sorted_pt = [&](int i) -> const Eigen::Vector2f& { return p[to_index(idx[to_index(i)])]; };
  int k = 0;
  for (int i = 0; i < n; ++i) {
    while (k >= 2 && cross2(hull_pt(k - 2), hull_pt(k - 1), sorted_pt(i)) <= 0) --k;
    h[to_index(k++)] = idx[to_index(i)];
  }
  for (int i = n - 2, t = k + 1; i >= 0; --i) {
    while (k >= t && cross2(hull_pt(k - 2), hull_pt(k - 1), sorted_pt(i)) <= 0) --k;
    h[to_index(k++)] = idx[to_index(i)];
  }
  h.resize(to_index(std::max(k - 1, 0)));
  return h;
}

// Drops hull vertices that are closer than `spacing` to the previous kept one, then the vertex whose removal loses
// the least area (Visvalingam) until at most `cap` remain: the hull keeps its corners, which make wide bases.
std::vector<int> simplify_hull(const std::vector<Eigen::Vector2f>& p, std::vector<int> h, float spacing, int cap) {
  std::vector<int> kept;
  for (int v : h) {
    if (!kept.empty() && (p[to_index(v)] - p[to_index(kept.back())]).norm() < spacing) continue;
    kept.push_back(v);
  }
  while (kept.size() > 3 && (p[to_index(kept.front())] - p[to_index(kept.back())]).norm() < spacing) kept.pop_back();
  while (static_cast<int>(kept.size()) > std::max(cap, 3)) {
    const std::size_t m = kept.size();
    std::size_t best = 0;
    double best_area = 1e300;
    for (std::size_t i = 0; i < m; ++i) {
      const double a = std::abs(cross2(p[to_index(kept[(i + m - 1) % m])], p[to_index(kept[i])], p[to_index(kept[(i + 1) % m])]));
      if (a < best_area) {
        best_area = a;
        best = i;
      }
    }
    kept.erase(kept.begin() + static_cast<std::ptrdiff_t>(best));
  }
  return kept;
}

// Member points into scratch->pts; returns their sum (double).
Eigen::Vector3d gather_members(const RangeImage& img, MemberSpan mem, std::vector<Eigen::Vector3f>* pts) {
  pts->clear();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int k : mem) {
    pts->push_back(img.xyz[to_index(k)]);
    sum += pts->back().cast<double>();
  }
  return sum;
}

using PcaSolver = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>;

// PCA of the members: centroid, extents, the plane test and (planar) the plane facing the sensor. cl->num_points is set.
PcaSolver fit_pca(const std::vector<Eigen::Vector3f>& pts, const Eigen::Vector3d& sum, const SegmentationConfig& config, Cluster* cl) {
  const Eigen::Vector3d mean = sum / cl->num_points;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) {
    const Eigen::Vector3d d = p.cast<double>() - mean;
    cov += d * d.transpose();
  }
  cov /= cl->num_points;
  cl->centroid = mean.cast<float>();
  PcaSolver es(cov);
  const Eigen::Vector3d ev = es.eigenvalues().cwiseMax(0.0);       // ascending
  cl->extent_major = static_cast<float>(std::sqrt(12.0 * ev(2)));  // width of a uniform strip with this variance
  cl->extent_minor = static_cast<float>(std::sqrt(12.0 * ev(1)));
  cl->planar = std::sqrt(ev(0)) < config.plane_rms_tolerance && cl->extent_minor >= config.min_plane_extent;
  if (cl->planar) {
    Eigen::Vector3d nrm = es.eigenvectors().col(0).normalized();
    if (nrm.dot(mean) > 0) nrm = -nrm;  // face the sensor
    cl->plane << nrm.cast<float>(), static_cast<float>(-nrm.dot(mean));
  }
  return es;
}

// Hull candidates: the cluster's boundary in the range image (per-column lowest/highest and per-row first/last
// pixel, as member positions in scratch->col_lo/col_hi/row_lo/row_hi, -1 none). The plane-to-image map is
// projective, so the plane hull's vertices are among them; far fewer to sort.
void mark_image_boundary(MemberSpan mem, int rows, int cols, ClusterScratch* s) {
  s->col_lo.assign(to_index(cols), -1);
  s->col_hi.assign(to_index(cols), -1);
  s->row_lo.assign(to_index(rows), -1);
  s->row_hi.assign(to_index(rows), -1);
  s->mem_row.resize(mem.size());
  s->mem_col.resize(mem.size());
  for (std::size_t i = 0; i < mem.size(); ++i) {
    s->mem_row[i] = mem[i] / cols;
    s->mem_col[i] = mem[i] - s->mem_row[i] * cols;
  }
  for (std::size_t i = 0; i < mem.size(); ++i) {
    const int r = s->mem_row[i], c = s->mem_col[i];
    const int mi = static_cast<int>(i);
    auto row_of = [&](int m) { return s->mem_row[to_index(m)]; };
    auto col_of = [&](int m) { return s->mem_col[to_index(m)]; };
    int& cl_lo = s->col_lo[to_index(c)];
    int& cl_hi = s->col_hi[to_index(c)];
    if (cl_lo < 0 || r < row_of(cl_lo)) cl_lo = mi;
    if (cl_hi < 0 || r > row_of(cl_hi)) cl_hi = mi;
    int& rw_lo = s->row_lo[to_index(r)];
    int& rw_hi = s->row_hi[to_index(r)];
    if (rw_lo < 0 || c < col_of(rw_lo)) rw_lo = mi;
    if (rw_hi < 0 || c > col_of(rw_hi)) rw_hi = mi;
  }
}

// Boundary members on the fitted plane into scratch->cand, sorted and unique. Members off the plane (a balcony merged
// through a smooth edge) are no hull candidates: bases built on the hull must be coplanar.
void on_plane_candidates(const Cluster& cl, const SegmentationConfig& config, ClusterScratch* s) {
  const float off_plane = static_cast<float>(3.0 * config.plane_rms_tolerance);
  s->cand.clear();
  for (const auto* v : {&s->col_lo, &s->col_hi, &s->row_lo, &s->row_hi})
    for (int mi : *v)
      if (mi >= 0 && std::abs(cl.plane.head<3>().dot(s->pts[to_index(mi)]) + cl.plane.w()) < off_plane) s->cand.push_back(mi);
  std::sort(s->cand.begin(), s->cand.end());
  s->cand.erase(std::unique(s->cand.begin(), s->cand.end()), s->cand.end());
}

// Convex hull of the candidates in the plane's (u, v) coordinates about the centroid, simplified, into cl->hull.
void plane_hull(const Eigen::Vector3f& u, const Eigen::Vector3f& v, const SegmentationConfig& config, ClusterScratch* s, Cluster* cl) {
  s->pts2.resize(s->cand.size());
  for (std::size_t i = 0; i < s->cand.size(); ++i) {
    const Eigen::Vector3f d = s->pts[to_index(s->cand[i])] - cl->centroid;
    s->pts2[i] = Eigen::Vector2f(d.dot(u), d.dot(v));
  }
  const auto hull = simplify_hull(s->pts2, convex_hull_2d(s->pts2), static_cast<float>(config.min_hull_spacing), config.max_hull_points);
  cl->hull.reserve(hull.size());
  for (int h : hull) cl->hull.push_back(s->pts[to_index(s->cand[to_index(h)])]);
}

}  // namespace

Cluster fit_cluster(const RangeImage& img, MemberSpan mem, const SegmentationConfig& config, ClusterScratch* scratch) {
  const Eigen::Vector3d sum = gather_members(img, mem, &scratch->pts);
  Cluster cl;
  cl.num_points = static_cast<int>(mem.size());
  const PcaSolver es = fit_pca(scratch->pts, sum, config, &cl);
  if (cl.planar) {
    const Eigen::Vector3f u = es.eigenvectors().col(2).cast<float>(), v = es.eigenvectors().col(1).cast<float>();
    mark_image_boundary(mem, img.rows, img.cols, scratch);
    on_plane_candidates(cl, config, scratch);
    plane_hull(u, v, config, scratch, &cl);
  }
  cl.points = downsample_members(scratch->pts, config.keep_voxel_size, config.max_kept_points_per_cluster);
  return cl;
}

}  // namespace loopd::detail
