// Region growing on the range image (Vlaminck 2019, Sec. 4.2.1): clusters grow over 4-neighbours (holes of one pixel
// are bridged) while two comparators hold, the Euclidean 3D distance and the surface-normal deviation.
#include <cmath>
#include <cstdint>
#include <utility>

#include "loopd/segmentation/segmentation_internal.hpp"

namespace loopd::detail {
namespace {

struct Pixel {
  int k, r, c;  // index, row, column (no division per popped pixel)
};

// Pixels that can join a cluster: valid with a known normal (1 byte each instead of testing the float normals).
std::vector<std::uint8_t> growable_pixels(const RangeImage& img) {
  std::vector<std::uint8_t> growable(img.index.size(), 0);
  for (std::size_t k = 0; k < img.index.size(); ++k) growable[k] = (img.index[k] >= 0 && !img.normal[k].isZero()) ? 1 : 0;
  return growable;
}

// One flood fill per unlabelled growable seed, seeds in row-major order; labels persist across seeds.
class RegionGrower {
 public:
  RegionGrower(const RangeImage& img, const SegmentationConfig& cfg)
      : img_(img),
        cfg_(cfg),
        cos_normal_(static_cast<float>(std::cos(cfg.max_normal_angle_deg * kPi / 180.0))),
        label_(img.index.size(), -1),
        growable_(growable_pixels(img)) {
    out_.flat.reserve(img.index.size());
  }

  RawClusters grow_all() {
    for (int seed_r = 0; seed_r < img_.rows; ++seed_r) {
      for (int seed_c = 0; seed_c < img_.cols; ++seed_c) {
        const std::size_t seed = pixel_index(seed_r, seed_c, img_.cols);
        if (!growable_[seed] || label_[seed] >= 0) continue;
        grow_cluster(Pixel{static_cast<int>(seed), seed_r, seed_c});
      }
    }
    out_.start.push_back(static_cast<int>(out_.flat.size()));
    return std::move(out_);
  }

 private:
  void grow_cluster(const Pixel& seed) {
    const int id = static_cast<int>(out_.start.size());
    out_.start.push_back(static_cast<int>(out_.flat.size()));
    label_[to_index(seed.k)] = id;
    stack_.assign(1, seed);
    while (!stack_.empty()) {
      const Pixel px = stack_.back();
      stack_.pop_back();
      out_.flat.push_back(px.k);
      visit_neighbours(px, id);
    }
  }

  // Pushes the neighbours of px that pass both comparators, nearest valid pixel within 2 steps in each direction.
  void visit_neighbours(const Pixel& px, int id) {
    const int cols = img_.cols, rows = img_.rows;
    const Eigen::Vector3f& p = img_.xyz[to_index(px.k)];
    const Eigen::Vector3f& n = img_.normal[to_index(px.k)];
    const float thr = neighbor_threshold(cfg_, img_.range[to_index(px.k)]);
    const float thr2 = thr * thr;
    // Same neighbour order as before (right, left, down, up): the growing order, and so every sum, is unchanged.
    auto visit = [&](int rr, int cc) {
      const int kk = rr * cols + cc;
      const auto skk = to_index(kk);
      if (label_[skk] >= 0 || !growable_[skk]) return;
      if (img_.normal[skk].dot(n) < cos_normal_) return;     // comparator 2
      if ((img_.xyz[skk] - p).squaredNorm() > thr2) return;  // comparator 1
      label_[skk] = id;
      stack_.push_back(Pixel{kk, rr, cc});
    };
    auto occupied = [&](int k) { return img_.index[to_index(k)] >= 0; };
    // Nearest valid pixel within 2 steps in each direction (holes of one pixel are bridged).
    const int base = px.r * cols;
    {
      const int c1 = wrap(px.c + 1, cols), c2 = wrap(px.c + 2, cols);
      if (occupied(base + c1))
        visit(px.r, c1);
      else if (occupied(base + c2))
        visit(px.r, c2);
    }
    {
      const int c1 = wrap(px.c - 1, cols), c2 = wrap(px.c - 2, cols);
      if (occupied(base + c1))
        visit(px.r, c1);
      else if (occupied(base + c2))
        visit(px.r, c2);
    }
    if (px.r + 1 < rows) {
      if (occupied(base + cols + px.c))
        visit(px.r + 1, px.c);
      else if (px.r + 2 < rows && occupied(base + 2 * cols + px.c))
        visit(px.r + 2, px.c);
    }
    if (px.r >= 1) {
      if (occupied(base - cols + px.c))
        visit(px.r - 1, px.c);
      else if (px.r >= 2 && occupied(base - 2 * cols + px.c))
        visit(px.r - 2, px.c);
    }
  }

  const RangeImage& img_;
  const SegmentationConfig& cfg_;
  const float cos_normal_;
  std::vector<int> label_;              // cluster id per pixel, -1 unlabelled
  std::vector<std::uint8_t> growable_;  // growable_pixels()
  std::vector<Pixel> stack_;
  RawClusters out_;
};

}  // namespace

RawClusters grow_regions(const RangeImage& img, const SegmentationConfig& cfg) { return RegionGrower(img, cfg).grow_all(); }

std::vector<int> largest_clusters(const RawClusters& raw, const SegmentationConfig& cfg) {
  std::vector<int> order;
  for (int i = 0; i < raw.num_clusters(); ++i)
    if (raw.size(i) >= cfg.min_cluster_points) order.push_back(i);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return raw.size(a) > raw.size(b); });
  if (static_cast<int>(order.size()) > cfg.max_clusters) order.resize(to_index(cfg.max_clusters));
  return order;
}

}  // namespace loopd::detail
