#include "loopd/base/kdtree.hpp"

#include <nanoflann.hpp>

namespace loopd {
namespace {
struct Adaptor {
  const std::vector<Eigen::Vector3f>* pts;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  float kdtree_get_pt(std::size_t i, std::size_t d) const { return (*pts)[i][static_cast<int>(d)]; }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Adaptor>, Adaptor, 3, std::uint32_t>;
}  // namespace

struct KdTree3f::Impl {
  Adaptor adaptor;
  Tree tree;
  Impl(const std::vector<Eigen::Vector3f>& p, int leaf)
      : adaptor{&p}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(static_cast<std::size_t>(leaf))) {}
};

KdTree3f::KdTree3f(const std::vector<Eigen::Vector3f>& points, int leaf_size) : impl_(std::make_unique<Impl>(points, leaf_size)) {
  if (!points.empty()) impl_->tree.buildIndex();
}
KdTree3f::~KdTree3f() = default;

std::size_t KdTree3f::size() const { return impl_->adaptor.pts->size(); }

bool KdTree3f::nearest(const Eigen::Vector3f& q, int* index, float* dist_sq) const {
  if (size() == 0) return false;
  std::uint32_t i = 0;
  float d = 0.f;
  nanoflann::KNNResultSet<float, std::uint32_t> rs(1);
  rs.init(&i, &d);
  impl_->tree.findNeighbors(rs, q.data(), nanoflann::SearchParams());
  if (rs.size() == 0) return false;
  *index = static_cast<int>(i);
  *dist_sq = d;
  return true;
}

int KdTree3f::knn(const Eigen::Vector3f& q, int k, int* indices, float* dists_sq) const {
  if (size() == 0 || k <= 0) return 0;
  // Small k (the common case: normals, correspondences) uses a stack buffer: no allocation per query.
  constexpr int kStack = 64;
  std::uint32_t stack_idx[kStack];
  std::vector<std::uint32_t> heap_idx;
  std::uint32_t* idx = stack_idx;
  if (k > kStack) {
    heap_idx.resize(static_cast<std::size_t>(k));
    idx = heap_idx.data();
  }
  nanoflann::KNNResultSet<float, std::uint32_t> rs(static_cast<std::size_t>(k));
  rs.init(idx, dists_sq);
  impl_->tree.findNeighbors(rs, q.data(), nanoflann::SearchParams());
  const int n = static_cast<int>(rs.size());
  for (int j = 0; j < n; ++j) indices[j] = static_cast<int>(idx[j]);
  return n;
}

void KdTree3f::radius(const Eigen::Vector3f& q, float radius, std::vector<int>* out) const {
  if (size() == 0) return;
  std::vector<std::pair<std::uint32_t, float>> matches;
  nanoflann::SearchParams params;
  params.sorted = false;
  impl_->tree.radiusSearch(q.data(), radius * radius, matches, params);
  for (const auto& m : matches) out->push_back(static_cast<int>(m.first));
}

}  // namespace loopd
