// Range-image segmentation (Vlaminck 2019, Sec. 4.2.1): the scan is projected on a rings x azimuth grid so that
// neighbouring points are found by adjacency, clusters grow over 4-neighbours with two comparators (Euclidean 3D
// distance and surface-normal deviation), and each cluster is tested for a plane (PCA) whose 2D convex hull is kept
// to pick wide coplanar 4PCS bases.
#include "loopd/segmentation/segmentation.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "loopd/core/lidar_model.hpp"
#include "loopd/core/stopwatch.hpp"

namespace loopd {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kDefaultColumns = 1024;
constexpr int kNormalColumnStep = 2;  // wider horizontal baseline: less range noise in the normals

struct RangeImage {
  int rows = 0, cols = 0;
  std::vector<int> index;       // point index per pixel, -1 empty
  std::vector<float> range;     // [m] per pixel
  std::vector<Eigen::Vector3f> xyz;  // point per pixel (copied: neighbour lookups stay local in memory)
  std::vector<Eigen::Vector3f> normal;  // unit normal per pixel, zero when unknown
  int at(int r, int c) const { return index[static_cast<std::size_t>(r * cols + c)]; }
};

// atan2 with |error| < 1e-5 rad: column binning needs far less, and libm's atan2 dominated the projection.
inline float fast_atan2(float y, float x) {
  const float ax = std::abs(x), ay = std::abs(y);
  const float mx = std::max(ax, ay);
  if (mx == 0.f) return 0.f;
  const float a = std::min(ax, ay) / mx;
  const float s = a * a;
  float r = ((-0.0464964749f * s + 0.15931422f) * s - 0.327622764f) * s * a + a;
  if (ay > ax) r = 1.57079637f - r;
  if (x < 0) r = 3.14159274f - r;
  return y < 0 ? -r : r;
}

inline int wrap(int c, int cols) { return c < 0 ? c + cols : (c >= cols ? c - cols : c); }

// Allowed distance between neighbouring pixels grows with range (the beams diverge).
inline float neighbor_threshold(const SegmentationConfig& cfg, float range) {
  return static_cast<float>(std::max(cfg.max_neighbor_distance, cfg.distance_range_scale * range));
}

// Ring boundaries of a lidar model as sin(elevation): the ring of a point is the number of boundaries below z / r.
// Same rule as ring_from_elevation (nearest ring, ties to the lower one, half a spacing of tolerance at both ends)
// without an asin and a double binary search per point.
struct RingTable {
  float lo = 0, hi = 0;     // sin of the accepted elevation interval
  std::vector<float> mids;  // sin of the midpoints between adjacent rings, ascending
  int ring(float s) const {
    if (!(s >= lo && s <= hi)) return -1;
    return static_cast<int>(std::lower_bound(mids.begin(), mids.end(), s) - mids.begin());
  }
};

RingTable make_ring_table(const LidarModel& model) {
  RingTable t;
  const auto& a = model.vertical_angles_deg;
  const double deg = kPi / 180.0;
  const double lo_tol = a.size() > 1 ? 0.5 * (a[1] - a[0]) : 1.0;
  const double hi_tol = a.size() > 1 ? 0.5 * (a[a.size() - 1] - a[a.size() - 2]) : 1.0;
  t.lo = static_cast<float>(std::sin(std::max(-90.0, a.front() - lo_tol) * deg));
  t.hi = static_cast<float>(std::sin(std::min(90.0, a.back() + hi_tol) * deg));
  for (std::size_t i = 0; i + 1 < a.size(); ++i) t.mids.push_back(static_cast<float>(std::sin(0.5 * (a[i] + a[i + 1]) * deg)));
  return t;
}

bool build_range_image(const PointCloud& scan, const LidarModel* model, const SegmentationConfig& cfg, RangeImage* img,
                       std::string* error) {
  const std::size_t n = scan.points.size();
  const float min_r = static_cast<float>(cfg.min_range), max_r = static_cast<float>(cfg.max_range);
  // Range per point, computed once; -1 marks unusable points (non-finite or outside [min_range, max_range]).
  std::vector<float> range(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = scan.points[i];
    const float r = p.norm();  // NaN/Inf fail the test below
    range[i] = (r >= min_r && r <= max_r && p.allFinite()) ? r : -1.f;
  }
  std::vector<int> row(n, -1);
  int rows = 0;
  if (scan.has_rings()) {
    rows = scan.num_rings;
    for (std::size_t i = 0; i < n; ++i) row[i] = scan.ring[i] < rows ? static_cast<int>(scan.ring[i]) : -1;
  } else if (model != nullptr && model->num_rings > 0 && !model->vertical_angles_deg.empty()) {
    rows = model->num_rings;
    const RingTable table = make_ring_table(*model);
    for (std::size_t i = 0; i < n; ++i)
      if (range[i] > 0.f) row[i] = table.ring(scan.points[i].z() / range[i]);
  } else if (model != nullptr && model->num_rings > 0) {
    rows = model->num_rings;  // a model without angles: ring_from_elevation gives -1 for every point
  } else {
    // No ring indices and no model: bin the elevations uniformly between the observed extremes.
    // sin(elevation) = z / r is binned instead of the angle: monotonic, nearly linear over a lidar's fan, no asin.
    rows = cfg.elevation_bins;
    float lo = 2.f, hi = -2.f;
    std::vector<float> el(n, 9.f);
    for (std::size_t i = 0; i < n; ++i) {
      if (!(range[i] > 0.f)) continue;
      el[i] = scan.points[i].z() / range[i];
      lo = std::min(lo, el[i]);
      hi = std::max(hi, el[i]);
    }
    if (hi > lo) {
      const float scale = static_cast<float>(rows) / (hi - lo);
      for (std::size_t i = 0; i < n; ++i)
        if (el[i] < 5.f) row[i] = std::min(rows - 1, static_cast<int>((el[i] - lo) * scale));
    }
  }
  if (rows <= 0) {
    *error = "no rings: scan has no ring indices and elevations could not be binned";
    return false;
  }
  const int cols = cfg.azimuth_columns > 0 ? cfg.azimuth_columns : kDefaultColumns;
  img->rows = rows;
  img->cols = cols;
  const std::size_t num_pixels = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols);
  img->index.assign(num_pixels, -1);
  img->range.assign(num_pixels, 0.f);
  img->xyz.resize(num_pixels);  // valid only where index >= 0
  const float col_scale = static_cast<float>(cols / (2.0 * kPi));
  for (std::size_t i = 0; i < n; ++i) {
    const float r = range[i];
    if (row[i] < 0 || r < 0.f) continue;
    const Eigen::Vector3f& p = scan.points[i];
    int c = static_cast<int>((fast_atan2(p.y(), p.x()) + static_cast<float>(kPi)) * col_scale);
    c = std::min(std::max(c, 0), cols - 1);
    const std::size_t k = static_cast<std::size_t>(row[i]) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(c);
    if (img->index[k] < 0 || r < img->range[k]) {  // keep the nearest return per pixel
      img->index[k] = static_cast<int>(i);
      img->range[k] = r;
      img->xyz[k] = p;
    }
  }
  return true;
}

// Nearest valid pixel in one direction (up to `max_step` pixels away, skipping holes), -1 if none.
inline int neighbor_pixel(const RangeImage& img, int r, int c, int dr, int dc, int max_step) {
  for (int s = 1; s <= max_step; ++s) {
    const int rr = r + dr * s;
    if (rr < 0 || rr >= img.rows) return -1;
    const int cc = wrap(c + dc * s, img.cols);
    const int k = rr * img.cols + cc;
    if (img.index[static_cast<std::size_t>(k)] >= 0) return k;
  }
  return -1;
}

void compute_normals(const SegmentationConfig& cfg, RangeImage* img) {
  const int rows = img->rows, cols = img->cols;
  std::vector<Eigen::Vector3f> raw(img->index.size(), Eigen::Vector3f::Zero());
  auto pt = [&](int k) -> const Eigen::Vector3f& { return img->xyz[static_cast<std::size_t>(k)]; };
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int k = r * cols + c;
      if (img->index[static_cast<std::size_t>(k)] < 0) continue;
      const Eigen::Vector3f& p = pt(k);
      const float thr = 2.f * neighbor_threshold(cfg, img->range[static_cast<std::size_t>(k)]);
      const float thr2 = thr * thr;
      auto tangent = [&](int dr, int dc, int step) -> Eigen::Vector3f {
        const int a = neighbor_pixel(*img, r, c, -dr, -dc, step), b = neighbor_pixel(*img, r, c, dr, dc, step);
        const bool ok_a = a >= 0 && (pt(a) - p).squaredNorm() < thr2, ok_b = b >= 0 && (pt(b) - p).squaredNorm() < thr2;
        if (ok_a && ok_b) return pt(b) - pt(a);
        if (ok_b) return pt(b) - p;
        if (ok_a) return p - pt(a);
        return Eigen::Vector3f::Zero();
      };
      const Eigen::Vector3f th = tangent(0, 1, 2 * kNormalColumnStep);
      const Eigen::Vector3f tv = tangent(1, 0, 2);
      Eigen::Vector3f nrm = th.cross(tv);
      const float len = nrm.norm();
      if (len <= 1e-9f || len < 1e-3f * th.norm() * tv.norm()) continue;
      nrm /= len;
      if (nrm.dot(p) > 0) nrm = -nrm;  // face the sensor
      raw[static_cast<std::size_t>(k)] = nrm;
    }
  }
  // 3x3 smoothing of the normals over pixels of the same surface (reduces range-noise wobble).
  img->normal.assign(raw.size(), Eigen::Vector3f::Zero());
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int k = r * cols + c;
      const Eigen::Vector3f& n0 = raw[static_cast<std::size_t>(k)];
      if (n0.isZero()) continue;
      const Eigen::Vector3f& p = pt(k);
      const float thr = neighbor_threshold(cfg, img->range[static_cast<std::size_t>(k)]);
      const float thr2 = thr * thr;
      Eigen::Vector3f acc = Eigen::Vector3f::Zero();
      for (int dr = -1; dr <= 1; ++dr) {
        const int rr = r + dr;
        if (rr < 0 || rr >= rows) continue;
        for (int dc = -1; dc <= 1; ++dc) {
          const int kk = rr * cols + wrap(c + dc, cols);
          const Eigen::Vector3f& nn = raw[static_cast<std::size_t>(kk)];
          if (nn.isZero() || nn.dot(n0) < 0.7f || (pt(kk) - p).squaredNorm() > thr2) continue;
          acc += nn;
        }
      }
      img->normal[static_cast<std::size_t>(k)] = acc.normalized();
    }
  }
}

/// A cluster's pixel indices inside the flat member array.
struct MemberSpan {
  const int* first;
  const int* last;
  std::size_t size() const { return static_cast<std::size_t>(last - first); }
  int operator[](std::size_t i) const { return first[i]; }
  const int* begin() const { return first; }
  const int* end() const { return last; }
};

struct Moments {
  int count = 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
};

struct VoxelKey {
  std::int64_t key;
  bool operator==(const VoxelKey& o) const { return key == o.key; }
};
struct VoxelHash {
  std::size_t operator()(const VoxelKey& k) const { return std::hash<std::int64_t>()(k.key); }
};

std::vector<Eigen::Vector3f> downsample_members(const std::vector<Eigen::Vector3f>& pts, double voxel, int cap) {
  std::unordered_map<VoxelKey, std::pair<Eigen::Vector3d, int>, VoxelHash> cells;
  cells.reserve(pts.size() / 4 + 1);
  std::vector<std::int64_t> order;
  const double inv = 1.0 / voxel;
  for (const auto& p : pts) {
    const std::int64_t x = static_cast<std::int64_t>(std::floor(p.x() * inv)) + (1 << 20);
    const std::int64_t y = static_cast<std::int64_t>(std::floor(p.y() * inv)) + (1 << 20);
    const std::int64_t z = static_cast<std::int64_t>(std::floor(p.z() * inv)) + (1 << 20);
    const VoxelKey key{(x << 42) | (y << 21) | z};
    auto it = cells.find(key);
    if (it == cells.end()) {
      cells.emplace(key, std::make_pair(p.cast<double>(), 1));
      order.push_back(key.key);
    } else {
      it->second.first += p.cast<double>();
      it->second.second += 1;
    }
  }
  std::sort(order.begin(), order.end());  // deterministic order independent of the hash table
  std::vector<Eigen::Vector3f> out;
  const std::size_t m = order.size();
  const std::size_t keep = std::min(m, static_cast<std::size_t>(cap));
  out.reserve(keep);
  for (std::size_t j = 0; j < keep; ++j) {
    const std::size_t i = keep == m ? j : (j * m) / keep;  // even stride over the sorted voxels
    const auto& cell = cells.at(VoxelKey{order[i]});
    out.push_back((cell.first / cell.second).cast<float>());
  }
  return out;
}

double cross2(const Eigen::Vector2f& o, const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
  return static_cast<double>(a.x() - o.x()) * (b.y() - o.y()) - static_cast<double>(a.y() - o.y()) * (b.x() - o.x());
}

// Andrew's monotone chain; returns member indices of the hull, counter-clockwise.
std::vector<int> convex_hull_2d(const std::vector<Eigen::Vector2f>& p) {
  const int n = static_cast<int>(p.size());
  std::vector<int> idx(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) idx[static_cast<std::size_t>(i)] = i;
  std::sort(idx.begin(), idx.end(), [&](int a, int b) {
    const auto& pa = p[static_cast<std::size_t>(a)];
    const auto& pb = p[static_cast<std::size_t>(b)];
    return pa.x() < pb.x() || (pa.x() == pb.x() && (pa.y() < pb.y() || (pa.y() == pb.y() && a < b)));
  });
  if (n < 3) return idx;
  std::vector<int> h(static_cast<std::size_t>(2 * n));
  int k = 0;
  for (int i = 0; i < n; ++i) {
    while (k >= 2 && cross2(p[static_cast<std::size_t>(h[static_cast<std::size_t>(k - 2)])], p[static_cast<std::size_t>(h[static_cast<std::size_t>(k - 1)])],
                            p[static_cast<std::size_t>(idx[static_cast<std::size_t>(i)])]) <= 0)
      --k;
    h[static_cast<std::size_t>(k++)] = idx[static_cast<std::size_t>(i)];
  }
  for (int i = n - 2, t = k + 1; i >= 0; --i) {
    while (k >= t && cross2(p[static_cast<std::size_t>(h[static_cast<std::size_t>(k - 2)])], p[static_cast<std::size_t>(h[static_cast<std::size_t>(k - 1)])],
                            p[static_cast<std::size_t>(idx[static_cast<std::size_t>(i)])]) <= 0)
      --k;
    h[static_cast<std::size_t>(k++)] = idx[static_cast<std::size_t>(i)];
  }
  h.resize(static_cast<std::size_t>(std::max(k - 1, 0)));
  return h;
}

// Drops hull vertices that are closer than `spacing` to the previous kept one, then the vertex whose removal loses
// the least area (Visvalingam) until at most `cap` remain: the hull keeps its corners, which make wide bases.
std::vector<int> simplify_hull(const std::vector<Eigen::Vector2f>& p, std::vector<int> h, float spacing, int cap) {
  std::vector<int> kept;
  for (int v : h) {
    if (!kept.empty() && (p[static_cast<std::size_t>(v)] - p[static_cast<std::size_t>(kept.back())]).norm() < spacing) continue;
    kept.push_back(v);
  }
  while (kept.size() > 3 && (p[static_cast<std::size_t>(kept.front())] - p[static_cast<std::size_t>(kept.back())]).norm() < spacing) kept.pop_back();
  while (static_cast<int>(kept.size()) > std::max(cap, 3)) {
    const std::size_t m = kept.size();
    std::size_t best = 0;
    double best_area = 1e300;
    for (std::size_t i = 0; i < m; ++i) {
      const double a = std::abs(cross2(p[static_cast<std::size_t>(kept[(i + m - 1) % m])], p[static_cast<std::size_t>(kept[i])],
                                       p[static_cast<std::size_t>(kept[(i + 1) % m])]));
      if (a < best_area) {
        best_area = a;
        best = i;
      }
    }
    kept.erase(kept.begin() + static_cast<std::ptrdiff_t>(best));
  }
  return kept;
}

}  // namespace

std::optional<std::string> SegmentationConfig::validate() const {
  if (max_neighbor_distance <= 0) return "max_neighbor_distance must be > 0";
  if (distance_range_scale < 0) return "distance_range_scale must be >= 0";
  if (max_normal_angle_deg <= 0 || max_normal_angle_deg >= 90) return "max_normal_angle_deg must be in (0, 90)";
  if (min_cluster_points < 3) return "min_cluster_points must be >= 3";
  if (plane_rms_tolerance <= 0) return "plane_rms_tolerance must be > 0";
  if (keep_voxel_size <= 0) return "keep_voxel_size must be > 0";
  if (max_kept_points_per_cluster < 1) return "max_kept_points_per_cluster must be >= 1";
  if (max_hull_points < 4) return "max_hull_points must be >= 4";
  if (max_clusters < 1) return "max_clusters must be >= 1";
  if (min_range < 0 || max_range <= min_range) return "need 0 <= min_range < max_range";
  if (azimuth_columns < 0) return "azimuth_columns must be >= 0";
  if (elevation_bins < 2) return "elevation_bins must be >= 2";
  return std::nullopt;
}

std::size_t Segmentation::bytes() const {
  std::size_t b = sizeof(Segmentation) + error.capacity() + clusters.capacity() * sizeof(Cluster);
  for (const auto& c : clusters) b += (c.points.capacity() + c.hull.capacity()) * sizeof(Eigen::Vector3f);
  return b;
}

int Segmentation::num_planar() const {
  int n = 0;
  for (const auto& c : clusters) n += c.planar ? 1 : 0;
  return n;
}

Segmentation segment(const PointCloud& scan, const LidarModel* model, const SegmentationConfig& config) {
  Stopwatch sw;
  Segmentation out;
  if (auto err = config.validate()) {
    out.error = "invalid SegmentationConfig: " + *err;
    return out;
  }
  if (scan.points.size() < static_cast<std::size_t>(config.min_cluster_points)) {
    out.error = "too few points to segment";
    out.ms = sw.ms();
    return out;
  }
  RangeImage img;
  if (!build_range_image(scan, model, config, &img, &out.error)) {
    out.ms = sw.ms();
    return out;
  }
  compute_normals(config, &img);

  // Region growing over 4-neighbours (holes of one pixel are bridged) with the two comparators of Sec. 4.2.1.
  const int cols = img.cols;
  const float cos_normal = static_cast<float>(std::cos(config.max_normal_angle_deg * kPi / 180.0));
  std::vector<int> label(img.index.size(), -1);
  std::vector<int> stack;
  // Members of all raw clusters in one flat array (a cluster's pixels are contiguous, in growing order):
  // cluster i is flat[start[i] .. start[i + 1]).
  std::vector<int> flat;
  flat.reserve(img.index.size() / 2);
  std::vector<int> start;
  const int dr4[4] = {0, 0, 1, -1}, dc4[4] = {1, -1, 0, 0};
  for (std::size_t seed = 0; seed < img.index.size(); ++seed) {
    if (img.index[seed] < 0 || label[seed] >= 0 || img.normal[seed].isZero()) continue;
    const int id = static_cast<int>(start.size());
    start.push_back(static_cast<int>(flat.size()));
    label[seed] = id;
    stack.assign(1, static_cast<int>(seed));
    while (!stack.empty()) {
      const int k = stack.back();
      stack.pop_back();
      flat.push_back(k);
      const int r = k / cols, c = k % cols;
      const Eigen::Vector3f& p = img.xyz[static_cast<std::size_t>(k)];
      const Eigen::Vector3f& n = img.normal[static_cast<std::size_t>(k)];
      const float thr = neighbor_threshold(config, img.range[static_cast<std::size_t>(k)]);
      for (int d = 0; d < 4; ++d) {
        const int kk = neighbor_pixel(img, r, c, dr4[d], dc4[d], 2);
        if (kk < 0 || label[static_cast<std::size_t>(kk)] >= 0) continue;
        const Eigen::Vector3f& nn = img.normal[static_cast<std::size_t>(kk)];
        if (nn.isZero() || nn.dot(n) < cos_normal) continue;                                                  // comparator 2
        if ((img.xyz[static_cast<std::size_t>(kk)] - p).squaredNorm() > thr * thr) continue;  // comparator 1
        label[static_cast<std::size_t>(kk)] = id;
        stack.push_back(kk);
      }
    }
  }

  // Largest clusters first (ties by first pixel: deterministic).
  start.push_back(static_cast<int>(flat.size()));
  auto cluster_size = [&](int i) { return start[static_cast<std::size_t>(i) + 1] - start[static_cast<std::size_t>(i)]; };
  std::vector<int> order;
  for (int i = 0; i + 1 < static_cast<int>(start.size()); ++i)
    if (cluster_size(i) >= config.min_cluster_points) order.push_back(i);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return cluster_size(a) > cluster_size(b); });
  if (static_cast<int>(order.size()) > config.max_clusters) order.resize(static_cast<std::size_t>(config.max_clusters));

  std::vector<Eigen::Vector3f> pts;
  std::vector<Eigen::Vector2f> pts2;
  std::vector<int> col_lo, col_hi, row_lo, row_hi, cand;
  for (int id : order) {
    const MemberSpan mem{flat.data() + start[static_cast<std::size_t>(id)], flat.data() + start[static_cast<std::size_t>(id) + 1]};
    pts.clear();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int k : mem) {
      pts.push_back(img.xyz[static_cast<std::size_t>(k)]);
      sum += pts.back().cast<double>();
    }
    Cluster cl;
    cl.num_points = static_cast<int>(mem.size());
    const Eigen::Vector3d mean = sum / cl.num_points;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& p : pts) {
      const Eigen::Vector3d d = p.cast<double>() - mean;
      cov += d * d.transpose();
    }
    cov /= cl.num_points;
    cl.centroid = mean.cast<float>();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    const Eigen::Vector3d ev = es.eigenvalues().cwiseMax(0.0);  // ascending
    cl.extent_major = static_cast<float>(std::sqrt(12.0 * ev(2)));  // width of a uniform strip with this variance
    cl.extent_minor = static_cast<float>(std::sqrt(12.0 * ev(1)));
    cl.planar = std::sqrt(ev(0)) < config.plane_rms_tolerance && cl.extent_minor >= config.min_plane_extent;
    if (cl.planar) {
      Eigen::Vector3d nrm = es.eigenvectors().col(0).normalized();
      if (nrm.dot(mean) > 0) nrm = -nrm;  // face the sensor
      cl.plane << nrm.cast<float>(), static_cast<float>(-nrm.dot(mean));
      const Eigen::Vector3f u = es.eigenvectors().col(2).cast<float>(), v = es.eigenvectors().col(1).cast<float>();
      // Hull candidates: the cluster's boundary in the range image (per-column lowest/highest and per-row first/last
      // pixel). The plane-to-image map is projective, so the plane hull's vertices are among them; far fewer to sort.
      col_lo.assign(static_cast<std::size_t>(cols), -1);
      col_hi.assign(static_cast<std::size_t>(cols), -1);
      row_lo.assign(static_cast<std::size_t>(img.rows), -1);
      row_hi.assign(static_cast<std::size_t>(img.rows), -1);
      for (std::size_t i = 0; i < mem.size(); ++i) {
        const int k = mem[i], r = k / cols, c = k % cols;
        const int mi = static_cast<int>(i);
        auto row_of = [&](int m) { return mem[static_cast<std::size_t>(m)] / cols; };
        auto col_of = [&](int m) { return mem[static_cast<std::size_t>(m)] % cols; };
        int& cl_lo = col_lo[static_cast<std::size_t>(c)];
        int& cl_hi = col_hi[static_cast<std::size_t>(c)];
        if (cl_lo < 0 || r < row_of(cl_lo)) cl_lo = mi;
        if (cl_hi < 0 || r > row_of(cl_hi)) cl_hi = mi;
        int& rw_lo = row_lo[static_cast<std::size_t>(r)];
        int& rw_hi = row_hi[static_cast<std::size_t>(r)];
        if (rw_lo < 0 || c < col_of(rw_lo)) rw_lo = mi;
        if (rw_hi < 0 || c > col_of(rw_hi)) rw_hi = mi;
      }
      // Members off the fitted plane (a balcony merged through a smooth edge) are no hull candidates: bases built on
      // the hull must be coplanar.
      const float off_plane = static_cast<float>(3.0 * config.plane_rms_tolerance);
      cand.clear();
      for (const auto* v : {&col_lo, &col_hi, &row_lo, &row_hi})
        for (int mi : *v)
          if (mi >= 0 && std::abs(cl.plane.head<3>().dot(pts[static_cast<std::size_t>(mi)]) + cl.plane.w()) < off_plane) cand.push_back(mi);
      std::sort(cand.begin(), cand.end());
      cand.erase(std::unique(cand.begin(), cand.end()), cand.end());
      pts2.resize(cand.size());
      for (std::size_t i = 0; i < cand.size(); ++i) {
        const Eigen::Vector3f d = pts[static_cast<std::size_t>(cand[i])] - cl.centroid;
        pts2[i] = Eigen::Vector2f(d.dot(u), d.dot(v));
      }
      const auto hull = simplify_hull(pts2, convex_hull_2d(pts2), static_cast<float>(config.min_hull_spacing), config.max_hull_points);
      cl.hull.reserve(hull.size());
      for (int h : hull) cl.hull.push_back(pts[static_cast<std::size_t>(cand[static_cast<std::size_t>(h)])]);
    }
    cl.points = downsample_members(pts, config.keep_voxel_size, config.max_kept_points_per_cluster);
    out.clusters.push_back(std::move(cl));
  }
  out.ms = sw.ms();
  return out;
}

}  // namespace loopd
