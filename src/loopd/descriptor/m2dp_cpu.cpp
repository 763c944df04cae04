// M2DP CPU reference (the oracle for the OpenCL backend): plain loops, double-precision moments,
// the same comparison binning as kernels/m2dp.cl, OpenMP over the projection planes.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "../../../kernels/m2dp_shared.h"
#include "loopd/base/target_clones.hpp"
#include "loopd/descriptor/m2dp_internal.hpp"

namespace loopd::detail {

namespace {

/// Points per binning block: coordinates (12 B/point) and temporaries (17 B/point) of a block stay in L1/L2.
constexpr int kBinBlock = 1024;

/// Per-thread temporaries of one block.
struct BinScratch {
  alignas(64) float u[kBinBlock];
  alignas(64) float v[kBinBlock];
  alignas(64) float r2[kBinBlock];
  alignas(64) float ring[kBinBlock];
  alignas(64) float k[kBinBlock];
  alignas(64) std::uint8_t bin[kBinBlock];
  alignas(64) std::uint16_t hist[4][M2DP_MAX_BINS];
};

/// Bin codes of m points on one plane for compile-time l = L and t = 4 (Q + 1): one element-wise loop with the ring
/// and sector comparisons unrolled, kept in registers (the general loops below go through the scratch arrays).
template <int L, int Q>
inline __attribute__((always_inline)) void codes_fixed(const float* __restrict xs, const float* __restrict ys, const float* __restrict zs, int m,
                                                       const float* pl, const float* params, std::uint8_t* __restrict bin) {
  const float e1x = pl[0], e1y = pl[1], e1z = pl[2], d1 = pl[3];
  const float e2x = pl[4], e2y = pl[5], e2z = pl[6], d2 = pl[7];
  float edge[static_cast<std::size_t>(L)], tq[static_cast<std::size_t>(Q + 1)];
  for (int k = 0; k < L - 1; ++k) edge[k] = params[k];
  for (int j = 0; j < Q; ++j) tq[j] = params[L - 1 + j];
  constexpr float kT = 4.0f * (Q + 1), kHalf = 2.0f * (Q + 1), kLast = 2.0f * (Q + 1) - 1.0f;
  for (int i = 0; i < m; ++i) {
    const float u = e1x * xs[i] + e1y * ys[i] + e1z * zs[i] + d1;
    const float v = e2x * xs[i] + e2y * ys[i] + e2z * zs[i] + d2;
    const float r2 = u * u + v * v;
    float ring = 0.0f;
#pragma GCC unroll 32
    for (int k = 0; k < L - 1; ++k) ring += static_cast<float>(r2 >= edge[k]);
    const float au = std::fabs(u), av = std::fabs(v);
    float kq = 0.0f;
#pragma GCC unroll 32
    for (int j = 0; j < Q; ++j) kq += static_cast<float>(av >= au * tq[j]);
    // Branch-free (0/1 floats) so that the loop vectorises: sector = (lower ? 0 : t/2) + (mirrored ? t/2-1-kq : kq).
    const float lower = static_cast<float>(v < 0.0f);
    const float mirrored = lower * static_cast<float>(u > 0.0f) + (1.0f - lower) * static_cast<float>(u < 0.0f);
    const float sector = (1.0f - lower) * kHalf + kq + mirrored * (kLast - 2.0f * kq);
    bin[i] = static_cast<std::uint8_t>(static_cast<int>(ring * kT + sector));
  }
}

/// Bin codes for any l, t (t a multiple of 4): loops interchanged so that each is a plain vectorisable loop.
inline __attribute__((always_inline)) void general_codes(const float* __restrict xs, const float* __restrict ys, const float* __restrict zs, int m,
                                                         const float* pl, const float* params, int l, int t, BinScratch* s) {
  const float e1x = pl[0], e1y = pl[1], e1z = pl[2], d1 = pl[3];
  const float e2x = pl[4], e2y = pl[5], e2z = pl[6], d2 = pl[7];
  float* __restrict u = s->u;
  float* __restrict v = s->v;
  float* __restrict r2 = s->r2;
  float* __restrict ring = s->ring;
  float* __restrict kk = s->k;
  for (int i = 0; i < m; ++i) {
    const float uu = e1x * xs[i] + e1y * ys[i] + e1z * zs[i] + d1;
    const float vv = e2x * xs[i] + e2y * ys[i] + e2z * zs[i] + d2;
    u[i] = uu;
    v[i] = vv;
    r2[i] = uu * uu + vv * vv;
    ring[i] = 0.0f;
    kk[i] = 0.0f;
  }
  for (int e = 0; e < l - 1; ++e) {
    const float edge = params[e];
    for (int i = 0; i < m; ++i) ring[i] += (r2[i] >= edge) ? 1.0f : 0.0f;
  }
  const float* tq = params + (l - 1);
  for (int j = 0; j < t / 4 - 1; ++j) {
    const float tj = tq[j];
    for (int i = 0; i < m; ++i) kk[i] += (std::fabs(v[i]) >= std::fabs(u[i]) * tj) ? 1.0f : 0.0f;
  }
  const float tf = static_cast<float>(t), half = static_cast<float>(t / 2), last = static_cast<float>(t / 2 - 1);
  std::uint8_t* __restrict bin = s->bin;
  for (int i = 0; i < m; ++i) {
    const float lower = v[i] < 0.0f ? 1.0f : 0.0f;
    const float mirrored = lower * (u[i] > 0.0f ? 1.0f : 0.0f) + (1.0f - lower) * (u[i] < 0.0f ? 1.0f : 0.0f);
    const float sector = (1.0f - lower) * half + kk[i] + mirrored * (last - 2.0f * kk[i]);
    bin[i] = static_cast<std::uint8_t>(static_cast<int>(ring[i] * tf + sector));
  }
}

/// Adds the counts of m bin codes to `counts` (nb bins).
inline __attribute__((always_inline)) void count_codes(const std::uint8_t* __restrict bin, int m, int nb, BinScratch* s,
                                                       std::uint32_t* __restrict counts) {
  // Four interleaved 16-bit histograms (a block has <= 1024 points): consecutive points in one bin do not wait on
  // each other's increment.
  for (int h = 0; h < 4; ++h)
    for (int b = 0; b < nb; ++b) s->hist[h][b] = 0;
  int i = 0;
  for (; i + 4 <= m; i += 4) {
    ++s->hist[0][bin[i]];
    ++s->hist[1][bin[i + 1]];
    ++s->hist[2][bin[i + 2]];
    ++s->hist[3][bin[i + 3]];
  }
  for (; i < m; ++i) ++s->hist[0][bin[i]];
  for (int b = 0; b < nb; ++b) counts[b] += static_cast<std::uint32_t>(s->hist[0][b]) + s->hist[1][b] + s->hist[2][b] + s->hist[3][b];
}

/// Projects m points onto one plane, bins them by comparisons (bin_of's arithmetic: squared radius against squared
/// ring edges, |v| against |u| tan(j 2 pi / t); no sqrt/atan2) and adds the counts to `counts` (l*t bins).
/// Each loop is a plain element-wise loop over the block so that the compiler vectorises it; target_clones builds
/// an AVX2 variant beside the SSE2 baseline and picks one at load time (no -march=native in a distributed binary).
/// No FMA in either variant (avx2 does not imply fma), so u, v round like kernels/m2dp.cl with FP_CONTRACT OFF.
LOOPD_TARGET_CLONES("avx2", "default")
void bin_and_count(const float* __restrict xs, const float* __restrict ys, const float* __restrict zs, int m, const float* pl, const float* params,
                   int l, int t, BinScratch* s, std::uint32_t* __restrict counts) {
  std::uint8_t* __restrict bin = s->bin;
  if (l == 8 && t == 16) {
    codes_fixed<8, 3>(xs, ys, zs, m, pl, params, bin);  // the paper's l = 8, t = 16
  } else {
    general_codes(xs, ys, zs, m, pl, params, l, t, s);
  }
  count_codes(bin, m, l * t, s, counts);
}

FirstMoments first_moments(const std::vector<Eigen::Vector3f>& points) {
  FirstMoments m;
  m.count = static_cast<double>(points.size());
  if (points.empty()) return m;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : points) sum += p.cast<double>();
  m.centroid = sum / m.count;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) {
    const Eigen::Vector3d q = p.cast<double>() - m.centroid;
    cov.noalias() += q * q.transpose();
  }
  m.covariance = cov / m.count;
  return m;
}

SecondMoments second_moments(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& centroid, const Eigen::Matrix3d& pca,
                             const Eigen::Matrix3d& sign_axes) {
  SecondMoments s;
  for (const auto& p : points) {
    const Eigen::Vector3d q = p.cast<double>() - centroid;
    s.max_r2 = std::max(s.max_r2, q.squaredNorm());
    const Eigen::Vector3d t = pca * q, w = sign_axes * q;
    s.third += w.cwiseProduct(w).cwiseProduct(w);
    s.second.noalias() += t * t.transpose();
    s.first += t;
  }
  return s;
}

}  // namespace

M2dpResult compute_m2dp_cpu(const std::vector<Eigen::Vector3f>& points, const M2dpConfig& config) {
  M2dpResult result;
  result.backend = Backend::kCpu;
  result.num_points = static_cast<int>(points.size());

  // Vlaminck 2019 Sec. 4.1, step 1: centroid; step 2: reference frame.
  const FirstMoments first = first_moments(points);
  if (std::string err = check_first(first); !err.empty()) {
    result.error = err;
    return result;
  }
  const Eigen::Matrix3d pca = pca_axes(first.covariance);
  const Eigen::Matrix3d sign_axes = frame_axes(first.covariance, config.frame);
  const SecondMoments second = second_moments(points, first.centroid, pca, sign_axes);
  const Frame f = finish_frame(first, pca, sign_axes, second, config.frame);
  if (!f.error.empty()) {
    result.error = f.error;
    return result;
  }
  result.axes = f.axes;
  result.centroid = f.centroid;
  result.max_radius = std::sqrt(f.max_r2);

  // Step 3: project onto the p*q planes and count points per (ring, sector) bin: signature matrix A.
  // Fused per block of points (pocl notes): the block's coordinates and per-plane temporaries stay in L1 while all
  // planes are projected, binned by comparisons and counted; threads take blocks and add their private matrices.
  const int num_planes = config.num_planes(), num_bins = config.num_bins();
  // max_points: only every stride-th point is binned (frame and radius above used all points).
  const std::size_t stride = static_cast<std::size_t>(binning_stride(points.size(), config.max_points));
  const int n = static_cast<int>((points.size() + stride - 1) / stride);
  result.num_points = n;
  // Structure of arrays, centred in float at the (refined) centroid; the plane offsets absorb the rounding.
  const Eigen::Vector3f c = f.centroid.cast<float>();
  std::vector<float> xs(static_cast<std::size_t>(n)), ys(static_cast<std::size_t>(n)), zs(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = points[static_cast<std::size_t>(i) * stride];
    xs[static_cast<std::size_t>(i)] = p.x() - c.x();
    ys[static_cast<std::size_t>(i)] = p.y() - c.y();
    zs[static_cast<std::size_t>(i)] = p.z() - c.z();
  }
  const std::vector<float> planes = plane_table(config, f.axes, f.centroid - c.cast<double>());
  const std::vector<float> params = bin_params(config, f.max_r2);
  std::vector<std::uint32_t> signature(static_cast<std::size_t>(num_planes) * static_cast<std::size_t>(num_bins), 0u);
  const int threads = config.num_threads > 0 ? config.num_threads : omp_get_max_threads();
  const int num_blocks = (n + kBinBlock - 1) / kBinBlock;

#pragma omp parallel num_threads(threads)
  {
    std::vector<std::uint32_t> local(signature.size(), 0u);
    BinScratch scratch;
#pragma omp for schedule(dynamic, 1)
    for (int blk = 0; blk < num_blocks; ++blk) {
      const int begin = blk * kBinBlock, m = std::min(kBinBlock, n - begin);
      for (int j = 0; j < num_planes; ++j)
        bin_and_count(xs.data() + begin, ys.data() + begin, zs.data() + begin, m, planes.data() + static_cast<std::size_t>(j) * M2DP_PLANE_STRIDE,
                      params.data(), config.num_rings_l, config.num_sectors_t, &scratch,
                      local.data() + static_cast<std::size_t>(j) * static_cast<std::size_t>(num_bins));
    }
#pragma omp critical(m2dp_signature_sum)
    for (std::size_t b = 0; b < signature.size(); ++b) signature[b] += local[b];
  }

  // Step 4: first left and right singular vectors of A.
  descriptor_from_signature(signature, config, &result);
  return result;
}

}  // namespace loopd::detail
