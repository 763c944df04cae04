// Range image of a scan (Vlaminck 2019, Sec. 4.2.1): rings x azimuth grid with the nearest return per pixel, and a
// surface normal per pixel from its neighbours in the grid.
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>

#include "loopd/base/fast_atan2.hpp"
#include "loopd/base/lidar_model.hpp"
#include "loopd/segmentation/segmentation_internal.hpp"

namespace loopd::detail {
namespace {

constexpr int kDefaultColumns = 1024;
constexpr int kNormalColumnStep = 2;  // wider horizontal baseline: less range noise in the normals
constexpr int kHorizontalSteps = 2 * kNormalColumnStep, kVerticalSteps = 2;

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
    int r = lut[to_index(b)];
    while (r < nm && mids[to_index(r)] < s) ++r;
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
      t.lut[to_index(b)] = static_cast<std::uint16_t>(std::lower_bound(t.mids.begin(), t.mids.end(), static_cast<float>(edge)) - t.mids.begin());
    }
  } else {
    t.lut.assign(1, 0);  // a single elevation: the forward scan from 0 is exact
  }
  return t;
}

// Row of a point: from the scan's ring indices, the model's elevations, or (neither) elevations binned between the
// extremes.
struct RowLookup {
  enum class Source { kScan, kModel, kNoAngles, kBinned } source = Source::kScan;
  int rows = 0;
  RingTable table;
  float bin_lo = 2.f, bin_scale = 0.f;

  // False when no point can be placed: a model without angles, or binned elevations without spread.
  bool places_points() const { return !(source == Source::kNoAngles || (source == Source::kBinned && !(bin_scale > 0.f))); }

  // -1: outside the rings. `r` is |p| (p = scan.points[i]).
  int row(const PointCloud& scan, std::size_t i, const Eigen::Vector3f& p, float r) const {
    switch (source) {
      case Source::kScan:
        return scan.ring[i] < rows ? static_cast<int>(scan.ring[i]) : -1;
      case Source::kModel:
        return table.ring(p.z() / r);
      default:
        return std::min(rows - 1, static_cast<int>((p.z() / r - bin_lo) * bin_scale));
    }
  }
};

RowLookup make_row_lookup(const PointCloud& scan, const LidarModel* model, const SegmentationConfig& cfg) {
  const float min_r = static_cast<float>(cfg.min_range), max_r = static_cast<float>(cfg.max_range);
  RowLookup rl;
  if (scan.has_rings()) {
    rl.source = RowLookup::Source::kScan;
    rl.rows = scan.num_rings;
  } else if (model != nullptr && model->num_rings > 0) {
    rl.rows = model->num_rings;
    rl.source = model->vertical_angles_deg.empty() ? RowLookup::Source::kNoAngles : RowLookup::Source::kModel;  // no angles: no ring
    if (rl.source == RowLookup::Source::kModel) rl.table = make_ring_table(*model);
  } else {
    // sin(elevation) = z / r is binned instead of the angle: monotonic, nearly linear over a lidar's fan, no asin.
    rl.source = RowLookup::Source::kBinned;
    rl.rows = cfg.elevation_bins;
    float hi = -2.f;
    for (const Eigen::Vector3f& p : scan.points) {
      const float r = p.norm();
      if (!(r >= min_r && r <= max_r) || !p.allFinite()) continue;
      const float e = p.z() / r;
      rl.bin_lo = std::min(rl.bin_lo, e);
      hi = std::max(hi, e);
    }
    if (hi > rl.bin_lo) rl.bin_scale = static_cast<float>(rl.rows) / (hi - rl.bin_lo);
  }
  return rl;
}

// One pass: range (once per point), row, column, nearest return per pixel.
void project_points(const PointCloud& scan, const RowLookup& rows, const SegmentationConfig& cfg, RangeImage* img) {
  const float min_r = static_cast<float>(cfg.min_range), max_r = static_cast<float>(cfg.max_range);
  const int cols = img->cols;
  const float col_scale = static_cast<float>(cols / (2.0 * kPi));
  int* const index = img->index.data();
  float* const range = img->range.data();
  Eigen::Vector3f* const xyz = img->xyz.data();
  const std::size_t n = scan.points.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = scan.points[i];
    const float r = p.norm();  // NaN/Inf fail the range test
    if (!(r >= min_r && r <= max_r) || !p.allFinite()) continue;
    const int row = rows.row(scan, i, p, r);
    if (row < 0) continue;
    int c = static_cast<int>((fast_atan2(p.y(), p.x()) + static_cast<float>(kPi)) * col_scale);
    c = std::min(std::max(c, 0), cols - 1);
    const std::size_t k = pixel_index(row, c, cols);
    if (index[k] < 0 || r < range[k]) {  // keep the nearest return per pixel
      index[k] = static_cast<int>(i);
      range[k] = r;
      xyz[k] = p;
    }
  }
}

// Tangent through p from its nearest valid pixels a and b (-1: none), each kept when within the threshold.
Eigen::Vector3f tangent(const std::vector<Eigen::Vector3f>& xyz, const Eigen::Vector3f& p, float thr2, std::ptrdiff_t a, std::ptrdiff_t b) {
  const bool ok_a = a >= 0 && (xyz[static_cast<std::size_t>(a)] - p).squaredNorm() < thr2;
  const bool ok_b = b >= 0 && (xyz[static_cast<std::size_t>(b)] - p).squaredNorm() < thr2;
  if (ok_a && ok_b) return xyz[static_cast<std::size_t>(b)] - xyz[static_cast<std::size_t>(a)];
  if (ok_b) return xyz[static_cast<std::size_t>(b)] - p;
  if (ok_a) return p - xyz[static_cast<std::size_t>(a)];
  return Eigen::Vector3f::Zero();
}

// Nearest valid pixel within kHorizontalSteps of column c in the row starting at `base`, towards -c (dir -1) or +c
// (dir +1), skipping holes; -1 when none.
std::ptrdiff_t nearest_in_row(const std::vector<std::uint8_t>& valid, std::size_t base, int c, int dir, int cols) {
  for (int st = 1; st <= kHorizontalSteps; ++st) {
    const std::size_t kk = base + to_index(wrap(dir < 0 ? c - st : c + st, cols));
    if (valid[kk]) return static_cast<std::ptrdiff_t>(kk);
  }
  return -1;
}

// Nearest valid pixel within kVerticalSteps of pixel k (row r) in its column, one row lower (dir -1) or higher (+1)
// at a time, skipping holes; -1 when none.
std::ptrdiff_t nearest_in_column(const std::vector<std::uint8_t>& valid, std::size_t k, int r, int dir, int rows, int cols) {
  for (int st = 1; st <= kVerticalSteps && (dir < 0 ? r - st >= 0 : r + st < rows); ++st) {
    const std::size_t step = to_index(st) * to_index(cols);
    const std::size_t kk = dir < 0 ? k - step : k + step;
    if (valid[kk]) return static_cast<std::ptrdiff_t>(kk);
  }
  return -1;
}

struct RawNormals {
  std::vector<Eigen::Vector3f> normal;  // unit normal per pixel where `known`
  std::vector<std::uint8_t> known;
};

// Unit normal of valid pixel k = (r, c) from its horizontal and vertical tangents, facing the sensor; false when
// degenerate.
bool pixel_normal(const SegmentationConfig& cfg, const RangeImage& img, const std::vector<std::uint8_t>& valid, int r, int c, Eigen::Vector3f* out) {
  const int rows = img.rows, cols = img.cols;
  const std::size_t base = to_index(r) * to_index(cols);
  const std::size_t k = base + to_index(c);
  const Eigen::Vector3f& p = img.xyz[k];
  const float thr = 2.f * neighbor_threshold(cfg, img.range[k]);
  const float thr2 = thr * thr;
  const Eigen::Vector3f th = tangent(img.xyz, p, thr2, nearest_in_row(valid, base, c, -1, cols), nearest_in_row(valid, base, c, +1, cols));
  const Eigen::Vector3f tv =
      tangent(img.xyz, p, thr2, nearest_in_column(valid, k, r, -1, rows, cols), nearest_in_column(valid, k, r, +1, rows, cols));
  Eigen::Vector3f nrm = th.cross(tv);
  const float len2 = nrm.squaredNorm();
  // |n| <= 1e-9 or |n| < 1e-3 |th| |tv| (nearly parallel tangents), in squares: one sqrt instead of three.
  if (len2 <= 1e-18f || len2 < 1e-6f * th.squaredNorm() * tv.squaredNorm()) return false;
  nrm /= std::sqrt(len2);
  if (nrm.dot(p) > 0) nrm = -nrm;  // face the sensor
  *out = nrm;
  return true;
}

RawNormals raw_normals(const SegmentationConfig& cfg, const RangeImage& img) {
  const std::size_t num_pixels = img.index.size();
  std::vector<std::uint8_t> valid(num_pixels);
  for (std::size_t k = 0; k < num_pixels; ++k) valid[k] = img.index[k] >= 0 ? 1 : 0;
  RawNormals raw;
  raw.normal.resize(num_pixels);
  raw.known.assign(num_pixels, 0);
  for (int r = 0; r < img.rows; ++r) {
    for (int c = 0; c < img.cols; ++c) {
      const std::size_t k = pixel_index(r, c, img.cols);
      if (!valid[k]) continue;
      if (pixel_normal(cfg, img, valid, r, c, &raw.normal[k])) raw.known[k] = 1;
    }
  }
  return raw;
}

// Mean of the raw normals in the 3x3 block around pixel k = (r, c) that agree with its own and lie within the
// neighbour threshold (same surface).
Eigen::Vector3f smoothed_normal(const SegmentationConfig& cfg, const RangeImage& img, const RawNormals& raw, int r, int c) {
  const int rows = img.rows, cols = img.cols;
  const int r_lo = std::max(r - 1, 0), r_hi = std::min(r + 1, rows - 1);
  const std::size_t k = pixel_index(r, c, cols);
  const Eigen::Vector3f& n0 = raw.normal[k];
  const Eigen::Vector3f& p = img.xyz[k];
  const float thr = neighbor_threshold(cfg, img.range[k]);
  const float thr2 = thr * thr;
  const int cm = wrap(c - 1, cols), cp = wrap(c + 1, cols);
  Eigen::Vector3f acc = Eigen::Vector3f::Zero();
  for (int rr = r_lo; rr <= r_hi; ++rr) {
    const std::size_t rb = to_index(rr) * to_index(cols);
    for (const int cc : {cm, c, cp}) {
      const std::size_t kk = rb + to_index(cc);
      if (!raw.known[kk]) continue;
      const Eigen::Vector3f& nn = raw.normal[kk];
      if (nn.dot(n0) < 0.7f || (img.xyz[kk] - p).squaredNorm() > thr2) continue;
      acc += nn;
    }
  }
  return acc.normalized();
}

}  // namespace

std::optional<std::string> build_range_image(const PointCloud& scan, const LidarModel* model, const SegmentationConfig& cfg, RangeImage* img) {
  const RowLookup rows = make_row_lookup(scan, model, cfg);
  if (rows.rows <= 0) return "no rings: scan has no ring indices and elevations could not be binned";
  const int cols = cfg.azimuth_columns > 0 ? cfg.azimuth_columns : kDefaultColumns;
  img->rows = rows.rows;
  img->cols = cols;
  const std::size_t num_pixels = to_index(rows.rows) * to_index(cols);
  img->index.assign(num_pixels, -1);
  img->range.assign(num_pixels, 0.f);
  img->xyz.resize(num_pixels);  // valid only where index >= 0
  if (rows.places_points()) project_points(scan, rows, cfg, img);
  return std::nullopt;
}

void compute_normals(const SegmentationConfig& cfg, RangeImage* img) {
  const RawNormals raw = raw_normals(cfg, *img);
  // 3x3 smoothing of the normals over pixels of the same surface (reduces range-noise wobble).
  img->normal.assign(img->index.size(), Eigen::Vector3f::Zero());
  for (int r = 0; r < img->rows; ++r) {
    for (int c = 0; c < img->cols; ++c) {
      const std::size_t k = pixel_index(r, c, img->cols);
      if (raw.known[k]) img->normal[k] = smoothed_normal(cfg, *img, raw, r, c);
    }
  }
}

}  // namespace loopd::detail
