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
  // Coarse lookup: lut[b] = number of mids below the start of bin b (minus half a bin, against rounding); the exact
  // count is reached by stepping forward, usually zero or one step (bins are much finer than the ring spacing).
  float lut_scale = 0;
  std::vector<std::uint16_t> lut;
  int ring(float s) const {
    if (!(s >= lo && s <= hi)) return -1;
    const int nm = static_cast<int>(mids.size());
    int b = static_cast<int>((s - lo) * lut_scale);
    b = std::min(std::max(b, 0), static_cast<int>(lut.size()) - 1);
    int r = lut[static_cast<std::size_t>(b)];
    while (r < nm && mids[static_cast<std::size_t>(r)] < s) ++r;
    return r;
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
  constexpr int kBins = 8192;
  if (t.hi > t.lo) {
    t.lut_scale = static_cast<float>(kBins / (static_cast<double>(t.hi) - t.lo));
    t.lut.resize(kBins + 1);
    for (int b = 0; b <= kBins; ++b) {
      const double edge = t.lo + (b - 0.5) / static_cast<double>(t.lut_scale);
      t.lut[static_cast<std::size_t>(b)] = static_cast<std::uint16_t>(
          std::lower_bound(t.mids.begin(), t.mids.end(), static_cast<float>(edge)) - t.mids.begin());
    }
  } else {
    t.lut.assign(1, 0);  // a single elevation: the forward scan from 0 is exact
  }
  return t;
}

bool build_range_image(const PointCloud& scan, const LidarModel* model, const SegmentationConfig& cfg, RangeImage* img,
                       std::string* error) {
  const std::size_t n = scan.points.size();
  const float min_r = static_cast<float>(cfg.min_range), max_r = static_cast<float>(cfg.max_range);
  // Ring source: the scan's ring indices, the model's elevations, or (neither) elevations binned between the extremes.
  enum class RingSource { kScan, kModel, kNoAngles, kBinned } source;
  int rows = 0;
  RingTable table;
  float bin_lo = 2.f, bin_scale = 0.f;
  if (scan.has_rings()) {
    source = RingSource::kScan;
    rows = scan.num_rings;
  } else if (model != nullptr && model->num_rings > 0) {
    rows = model->num_rings;
    source = model->vertical_angles_deg.empty() ? RingSource::kNoAngles : RingSource::kModel;  // no angles: no ring
    if (source == RingSource::kModel) table = make_ring_table(*model);
  } else {
    // sin(elevation) = z / r is binned instead of the angle: monotonic, nearly linear over a lidar's fan, no asin.
    source = RingSource::kBinned;
    rows = cfg.elevation_bins;
    float hi = -2.f;
    for (const Eigen::Vector3f& p : scan.points) {
      const float r = p.norm();
      if (!(r >= min_r && r <= max_r) || !p.allFinite()) continue;
      const float e = p.z() / r;
      bin_lo = std::min(bin_lo, e);
      hi = std::max(hi, e);
    }
    if (hi > bin_lo) bin_scale = static_cast<float>(rows) / (hi - bin_lo);
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
  if (source == RingSource::kNoAngles || (source == RingSource::kBinned && !(bin_scale > 0.f))) return true;
  const float col_scale = static_cast<float>(cols / (2.0 * kPi));
  int* const index = img->index.data();
  float* const range = img->range.data();
  Eigen::Vector3f* const xyz = img->xyz.data();
  // One pass: range (once per point), ring, column, nearest return per pixel.
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = scan.points[i];
    const float r = p.norm();  // NaN/Inf fail the range test
    if (!(r >= min_r && r <= max_r) || !p.allFinite()) continue;
    int row = -1;
    switch (source) {
      case RingSource::kScan:
        row = scan.ring[i] < rows ? static_cast<int>(scan.ring[i]) : -1;
        break;
      case RingSource::kModel:
        row = table.ring(p.z() / r);
        break;
      default:
        row = std::min(rows - 1, static_cast<int>((p.z() / r - bin_lo) * bin_scale));
        break;
    }
    if (row < 0) continue;
    int c = static_cast<int>((fast_atan2(p.y(), p.x()) + static_cast<float>(kPi)) * col_scale);
    c = std::min(std::max(c, 0), cols - 1);
    const std::size_t k = static_cast<std::size_t>(row) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(c);
    if (index[k] < 0 || r < range[k]) {  // keep the nearest return per pixel
      index[k] = static_cast<int>(i);
      range[k] = r;
      xyz[k] = p;
    }
  }
  return true;
}

void compute_normals(const SegmentationConfig& cfg, RangeImage* img) {
  const int rows = img->rows, cols = img->cols;
  const std::size_t num_pixels = img->index.size();
  const std::vector<Eigen::Vector3f>& xyz = img->xyz;
  const std::vector<float>& range = img->range;
  std::vector<std::uint8_t> valid(num_pixels);
  for (std::size_t k = 0; k < num_pixels; ++k) valid[k] = img->index[k] >= 0 ? 1 : 0;
  const double min_thr = cfg.max_neighbor_distance, thr_scale = cfg.distance_range_scale;
  auto threshold = [&](std::size_t k) { return static_cast<float>(std::max(min_thr, thr_scale * range[k])); };  // neighbor_threshold
  std::vector<Eigen::Vector3f> raw(num_pixels);
  std::vector<std::uint8_t> has_raw(num_pixels, 0);  // raw[k] is set (a unit normal)
  constexpr int kHorizontalSteps = 2 * kNormalColumnStep, kVerticalSteps = 2;
  for (int r = 0; r < rows; ++r) {
    const std::size_t base = static_cast<std::size_t>(r) * static_cast<std::size_t>(cols);
    for (int c = 0; c < cols; ++c) {
      const std::size_t k = base + static_cast<std::size_t>(c);
      if (!valid[k]) continue;
      const Eigen::Vector3f& p = xyz[k];
      const float thr = 2.f * threshold(k);
      const float thr2 = thr * thr;
      // Nearest valid pixel on each side (skipping holes, as neighbor_pixel), kept when within the threshold.
      auto tangent = [&](std::ptrdiff_t a, std::ptrdiff_t b) -> Eigen::Vector3f {
        const bool ok_a = a >= 0 && (xyz[static_cast<std::size_t>(a)] - p).squaredNorm() < thr2;
        const bool ok_b = b >= 0 && (xyz[static_cast<std::size_t>(b)] - p).squaredNorm() < thr2;
        if (ok_a && ok_b) return xyz[static_cast<std::size_t>(b)] - xyz[static_cast<std::size_t>(a)];
        if (ok_b) return xyz[static_cast<std::size_t>(b)] - p;
        if (ok_a) return p - xyz[static_cast<std::size_t>(a)];
        return Eigen::Vector3f::Zero();
      };
      std::ptrdiff_t left = -1, right = -1, down = -1, up = -1;
      for (int st = 1; st <= kHorizontalSteps; ++st) {
        const std::size_t kk = base + static_cast<std::size_t>(wrap(c - st, cols));
        if (valid[kk]) {
          left = static_cast<std::ptrdiff_t>(kk);
          break;
        }
      }
      for (int st = 1; st <= kHorizontalSteps; ++st) {
        const std::size_t kk = base + static_cast<std::size_t>(wrap(c + st, cols));
        if (valid[kk]) {
          right = static_cast<std::ptrdiff_t>(kk);
          break;
        }
      }
      for (int st = 1; st <= kVerticalSteps && r - st >= 0; ++st) {
        const std::size_t kk = k - static_cast<std::size_t>(st) * static_cast<std::size_t>(cols);
        if (valid[kk]) {
          down = static_cast<std::ptrdiff_t>(kk);
          break;
        }
      }
      for (int st = 1; st <= kVerticalSteps && r + st < rows; ++st) {
        const std::size_t kk = k + static_cast<std::size_t>(st) * static_cast<std::size_t>(cols);
        if (valid[kk]) {
          up = static_cast<std::ptrdiff_t>(kk);
          break;
        }
      }
      const Eigen::Vector3f th = tangent(left, right);
      const Eigen::Vector3f tv = tangent(down, up);
      Eigen::Vector3f nrm = th.cross(tv);
      const float len2 = nrm.squaredNorm();
      // |n| <= 1e-9 or |n| < 1e-3 |th| |tv| (nearly parallel tangents), in squares: one sqrt instead of three.
      if (len2 <= 1e-18f || len2 < 1e-6f * th.squaredNorm() * tv.squaredNorm()) continue;
      nrm /= std::sqrt(len2);
      if (nrm.dot(p) > 0) nrm = -nrm;  // face the sensor
      raw[k] = nrm;
      has_raw[k] = 1;
    }
  }
  // 3x3 smoothing of the normals over pixels of the same surface (reduces range-noise wobble).
  img->normal.assign(num_pixels, Eigen::Vector3f::Zero());
  for (int r = 0; r < rows; ++r) {
    const int r_lo = std::max(r - 1, 0), r_hi = std::min(r + 1, rows - 1);
    for (int c = 0; c < cols; ++c) {
      const std::size_t k = static_cast<std::size_t>(r) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(c);
      if (!has_raw[k]) continue;
      const Eigen::Vector3f& n0 = raw[k];
      const Eigen::Vector3f& p = xyz[k];
      const float thr = threshold(k);
      const float thr2 = thr * thr;
      const int cm = wrap(c - 1, cols), cp = wrap(c + 1, cols);
      Eigen::Vector3f acc = Eigen::Vector3f::Zero();
      for (int rr = r_lo; rr <= r_hi; ++rr) {
        const std::size_t rb = static_cast<std::size_t>(rr) * static_cast<std::size_t>(cols);
        for (const int cc : {cm, c, cp}) {
          const std::size_t kk = rb + static_cast<std::size_t>(cc);
          if (!has_raw[kk]) continue;
          const Eigen::Vector3f& nn = raw[kk];
          if (nn.dot(n0) < 0.7f || (xyz[kk] - p).squaredNorm() > thr2) continue;
          acc += nn;
        }
      }
      img->normal[k] = acc.normalized();
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

Segmentation segment(const PointCloud& scan, const LidarModel* model, const SegmentationConfig& config,
                     std::vector<Eigen::Vector3f>* point_normals) {
  Stopwatch sw;
  Segmentation out;
  if (point_normals) point_normals->assign(scan.points.size(), Eigen::Vector3f::Zero());
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
  if (point_normals) {
    for (std::size_t k = 0; k < img.index.size(); ++k)
      if (img.index[k] >= 0) (*point_normals)[static_cast<std::size_t>(img.index[k])] = img.normal[k];
  }

  // Region growing over 4-neighbours (holes of one pixel are bridged) with the two comparators of Sec. 4.2.1.
  const int cols = img.cols;
  const float cos_normal = static_cast<float>(std::cos(config.max_normal_angle_deg * kPi / 180.0));
  std::vector<int> label(img.index.size(), -1);
  // Pixels that can join a cluster: valid with a known normal (1 byte each instead of testing the float normals).
  std::vector<std::uint8_t> growable(img.index.size(), 0);
  for (std::size_t k = 0; k < img.index.size(); ++k) growable[k] = (img.index[k] >= 0 && !img.normal[k].isZero()) ? 1 : 0;
  struct Pixel {
    int k, r, c;  // index, row, column (no division per popped pixel)
  };
  std::vector<Pixel> stack;
  // Members of all raw clusters in one flat array (a cluster's pixels are contiguous, in growing order):
  // cluster i is flat[start[i] .. start[i + 1]).
  std::vector<int> flat;
  flat.reserve(img.index.size());
  std::vector<int> start;
  const int rows = img.rows;
  for (int seed_r = 0; seed_r < rows; ++seed_r) {
    for (int seed_c = 0; seed_c < cols; ++seed_c) {
      const std::size_t seed = static_cast<std::size_t>(seed_r) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(seed_c);
      if (!growable[seed] || label[seed] >= 0) continue;
      const int id = static_cast<int>(start.size());
      start.push_back(static_cast<int>(flat.size()));
      label[seed] = id;
      stack.assign(1, Pixel{static_cast<int>(seed), seed_r, seed_c});
      while (!stack.empty()) {
        const Pixel px = stack.back();
        stack.pop_back();
        flat.push_back(px.k);
        const Eigen::Vector3f& p = img.xyz[static_cast<std::size_t>(px.k)];
        const Eigen::Vector3f& n = img.normal[static_cast<std::size_t>(px.k)];
        const float thr = neighbor_threshold(config, img.range[static_cast<std::size_t>(px.k)]);
        const float thr2 = thr * thr;
        // Same neighbour order as before (right, left, down, up): the growing order, and so every sum, is unchanged.
        auto visit = [&](int rr, int cc) {
          const int kk = rr * cols + cc;
          const auto skk = static_cast<std::size_t>(kk);
          if (label[skk] >= 0 || !growable[skk]) return;
          if (img.normal[skk].dot(n) < cos_normal) return;           // comparator 2
          if ((img.xyz[skk] - p).squaredNorm() > thr2) return;       // comparator 1
          label[skk] = id;
          stack.push_back(Pixel{kk, rr, cc});
        };
        // Nearest valid pixel within 2 steps in each direction (holes of one pixel are bridged).
        const int base = px.r * cols;
        {
          const int c1 = wrap(px.c + 1, cols), c2 = wrap(px.c + 2, cols);
          if (img.index[static_cast<std::size_t>(base + c1)] >= 0) visit(px.r, c1);
          else if (img.index[static_cast<std::size_t>(base + c2)] >= 0) visit(px.r, c2);
        }
        {
          const int c1 = wrap(px.c - 1, cols), c2 = wrap(px.c - 2, cols);
          if (img.index[static_cast<std::size_t>(base + c1)] >= 0) visit(px.r, c1);
          else if (img.index[static_cast<std::size_t>(base + c2)] >= 0) visit(px.r, c2);
        }
        if (px.r + 1 < rows) {
          if (img.index[static_cast<std::size_t>(base + cols + px.c)] >= 0) visit(px.r + 1, px.c);
          else if (px.r + 2 < rows && img.index[static_cast<std::size_t>(base + 2 * cols + px.c)] >= 0) visit(px.r + 2, px.c);
        }
        if (px.r >= 1) {
          if (img.index[static_cast<std::size_t>(base - cols + px.c)] >= 0) visit(px.r - 1, px.c);
          else if (px.r >= 2 && img.index[static_cast<std::size_t>(base - 2 * cols + px.c)] >= 0) visit(px.r - 2, px.c);
        }
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
  std::vector<int> col_lo, col_hi, row_lo, row_hi, cand, mem_row, mem_col;
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
      mem_row.resize(mem.size());
      mem_col.resize(mem.size());
      for (std::size_t i = 0; i < mem.size(); ++i) {
        mem_row[i] = mem[i] / cols;
        mem_col[i] = mem[i] - mem_row[i] * cols;
      }
      for (std::size_t i = 0; i < mem.size(); ++i) {
        const int r = mem_row[i], c = mem_col[i];
        const int mi = static_cast<int>(i);
        auto row_of = [&](int m) { return mem_row[static_cast<std::size_t>(m)]; };
        auto col_of = [&](int m) { return mem_col[static_cast<std::size_t>(m)]; };
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
