// M2DP descriptor kernels (He et al. 2016; Vlaminck et al. 2019, Sec. 4.1).
//
// The host prepends the text of m2dp_shared.h and defines M2DP_L (rings), M2DP_T (sectors, even)
// and M2DP_NPLANES (p * q). Shaped for PoCL on a CPU as much as for a GPU (see
// shared/notes/opencl-on-pocl.md): one work-item per chunk of points (and per plane for the
// binning), bins found by comparisons instead of atan2/sqrt, no atomics, and the per-point work
// in plain loops over contiguous arrays that the compiler can vectorise.

// No FMA contraction: u, v and the sector test round exactly like the CPU reference (fewer boundary flips).
#pragma OPENCL FP_CONTRACT OFF

#define M2DP_LT (M2DP_L * M2DP_T)
#define M2DP_HALF_T (M2DP_T / 2)

// Pass 1 (reduction): shifts the points by `shift` (float precision), converts them from xyz
// triplets to three contiguous arrays, and writes per-chunk sums for the centroid and covariance.
__kernel void m2dp_moments(__global const float* xyz, const int n, const float sx, const float sy, const float sz,
                           __global float* xs, __global float* ys, __global float* zs, __global float* moments) {
  const int chunk = (int)get_global_id(0);
  const int begin = chunk * M2DP_CHUNK;
  const int end = min(n, begin + M2DP_CHUNK);
  float s_x = 0.0f, s_y = 0.0f, s_z = 0.0f;
  float s_xx = 0.0f, s_xy = 0.0f, s_xz = 0.0f, s_yy = 0.0f, s_yz = 0.0f, s_zz = 0.0f;
  for (int i = begin; i < end; ++i) {
    const float x = xyz[3 * i] - sx, y = xyz[3 * i + 1] - sy, z = xyz[3 * i + 2] - sz;
    xs[i] = x;
    ys[i] = y;
    zs[i] = z;
    s_x += x;
    s_y += y;
    s_z += z;
    s_xx += x * x;
    s_xy += x * y;
    s_xz += x * z;
    s_yy += y * y;
    s_yz += y * z;
    s_zz += z * z;
  }
  __global float* m = moments + chunk * M2DP_MOMENT_STRIDE;
  m[0] = (float)(end - begin);
  m[1] = s_x;
  m[2] = s_y;
  m[3] = s_z;
  m[4] = s_xx;
  m[5] = s_xy;
  m[6] = s_xz;
  m[7] = s_yy;
  m[8] = s_yz;
  m[9] = s_zz;
  m[10] = 0.0f;
  m[11] = 0.0f;
}

// Pass 2 (reduction): per chunk, the largest squared distance to the centroid c (the outer ring
// radius), the third moments along the sign axes b0, b1, b2 (for their canonical signs), and the
// centred first and second moments in the pass-1 PCA axes a0, a1, a2 (the host refines the centroid
// and axes with them; accurate because the coordinates are centred and nearly decorrelated).
// frame = {cx, cy, cz, a0 (3), a1 (3), a2 (3), b0 (3), b1 (3), b2 (3)}.
__kernel void m2dp_extent(__global const float* xs, __global const float* ys, __global const float* zs, const int n,
                          __constant float* frame, __global float* extent) {
  const int chunk = (int)get_global_id(0);
  const int begin = chunk * M2DP_CHUNK;
  const int end = min(n, begin + M2DP_CHUNK);
  const float cx = frame[0], cy = frame[1], cz = frame[2];
  const float a0x = frame[3], a0y = frame[4], a0z = frame[5];
  const float a1x = frame[6], a1y = frame[7], a1z = frame[8];
  const float a2x = frame[9], a2y = frame[10], a2z = frame[11];
  const float b0x = frame[12], b0y = frame[13], b0z = frame[14];
  const float b1x = frame[15], b1y = frame[16], b1z = frame[17];
  const float b2x = frame[18], b2y = frame[19], b2z = frame[20];
  float max_r2 = 0.0f, m0 = 0.0f, m1 = 0.0f, m2 = 0.0f;
  float s00 = 0.0f, s01 = 0.0f, s02 = 0.0f, s11 = 0.0f, s12 = 0.0f, s22 = 0.0f;
  float f0 = 0.0f, f1 = 0.0f, f2 = 0.0f;
  for (int i = begin; i < end; ++i) {
    const float x = xs[i] - cx, y = ys[i] - cy, z = zs[i] - cz;
    max_r2 = fmax(max_r2, x * x + y * y + z * z);
    const float t0 = a0x * x + a0y * y + a0z * z;
    const float t1 = a1x * x + a1y * y + a1z * z;
    const float t2 = a2x * x + a2y * y + a2z * z;
    const float w0 = b0x * x + b0y * y + b0z * z;
    const float w1 = b1x * x + b1y * y + b1z * z;
    const float w2 = b2x * x + b2y * y + b2z * z;
    m0 += w0 * w0 * w0;
    m1 += w1 * w1 * w1;
    m2 += w2 * w2 * w2;
    s00 += t0 * t0;
    s01 += t0 * t1;
    s02 += t0 * t2;
    s11 += t1 * t1;
    s12 += t1 * t2;
    s22 += t2 * t2;
    f0 += t0;
    f1 += t1;
    f2 += t2;
  }
  __global float* e = extent + chunk * M2DP_EXTENT_STRIDE;
  e[0] = max_r2;
  e[1] = m0;
  e[2] = m1;
  e[3] = m2;
  e[4] = s00;
  e[5] = s01;
  e[6] = s02;
  e[7] = s11;
  e[8] = s12;
  e[9] = s22;
  e[10] = f0;
  e[11] = f1;
  e[12] = f2;
  e[13] = 0.0f;
  e[14] = 0.0f;
  e[15] = 0.0f;
}

// Pass 3a: bin code of every (plane, binned point); one work-item per M2DP_VEC = 8 consecutive binned
// points, explicit float8 arithmetic over the points (SIMD on a CPU device without relying on PoCL's
// work-group vectoriser, which left the scalar version of this kernel unvectorised here), a loop over
// all planes with plane parameters uniform across work-items, contiguous uchar8 stores.
// Vlaminck 2019 Sec. 4.1: a point projects onto plane X_j at (u, v) = (e1.p, e2.p) relative to the
// projected centroid; rings have outer radii k^2 r (k = 1..l, l^2 r = farthest point) and each ring
// has t sectors over (-pi, pi]. Ring: count of squared edges (k^2 r)^2 <= u^2 + v^2. Sector: the half
// turn from the sign of v, the quarter from the sign of the folded u, and inside the quarter the count
// of boundaries with |v| >= |u| tan(j 2 pi / t), mirrored in the second quarter (the same arithmetic
// as bin_of() and the CPU loops in src/loopd/descriptor: no sqrt, no atan2, no atomics, no branches).
// The k-th binned point is xs[k * stride] (max_points subsampling of the binning only); lanes past n
// repeat the last point into the padding, which pass 3b ignores.
// bin_params = {(k^2 r)^2 for k = 1..l-1, then tan(j 2 pi / t) for j = 1..t/4-1}.
#define M2DP_LANE(k) (min(base + (k), n - 1) * stride)
__kernel __attribute__((reqd_work_group_size(M2DP_WG, 1, 1)))
void m2dp_codes(__global const float* xs, __global const float* ys, __global const float* zs, const int n, const int stride,
                __constant float* planes, __constant float* bin_params, __global uchar* codes, const int n_pad) {
  const int base = (int)get_global_id(0) * M2DP_VEC;
  float16 x, y, z;
  if (stride == 1 && base + M2DP_VEC <= n) {
    x = vload16(0, xs + base);
    y = vload16(0, ys + base);
    z = vload16(0, zs + base);
  } else {
    int g[16];
    for (int k = 0; k < 16; ++k) g[k] = M2DP_LANE(k);
    x = (float16)(xs[g[0]], xs[g[1]], xs[g[2]], xs[g[3]], xs[g[4]], xs[g[5]], xs[g[6]], xs[g[7]], xs[g[8]], xs[g[9]], xs[g[10]], xs[g[11]], xs[g[12]], xs[g[13]], xs[g[14]], xs[g[15]]);
    y = (float16)(ys[g[0]], ys[g[1]], ys[g[2]], ys[g[3]], ys[g[4]], ys[g[5]], ys[g[6]], ys[g[7]], ys[g[8]], ys[g[9]], ys[g[10]], ys[g[11]], ys[g[12]], ys[g[13]], ys[g[14]], ys[g[15]]);
    z = (float16)(zs[g[0]], zs[g[1]], zs[g[2]], zs[g[3]], zs[g[4]], zs[g[5]], zs[g[6]], zs[g[7]], zs[g[8]], zs[g[9]], zs[g[10]], zs[g[11]], zs[g[12]], zs[g[13]], zs[g[14]], zs[g[15]]);
  }
  for (int plane = 0; plane < M2DP_NPLANES; ++plane) {
    __constant float* pl = planes + plane * M2DP_PLANE_STRIDE;
    const float16 u = pl[0] * x + pl[1] * y + pl[2] * z + pl[3];
    const float16 v = pl[4] * x + pl[5] * y + pl[6] * z + pl[7];
    const float16 r2 = u * u + v * v;
    int16 ring = (int16)(0);
#pragma unroll
    for (int k = 0; k < M2DP_L - 1; ++k) ring -= (r2 >= bin_params[k]);  // true is -1 per lane
    const float16 au = fabs(u), av = fabs(v);
    int16 kq = (int16)(0);
#pragma unroll
    for (int j = 0; j < M2DP_T / 4 - 1; ++j) kq -= (av >= au * bin_params[M2DP_L - 1 + j]);
    const int16 lower = v < 0.0f;
    const int16 mirrored = (lower & (u > 0.0f)) | (~lower & (u < 0.0f));
    const int16 sector = select((int16)(M2DP_HALF_T), (int16)(0), lower) + select(kq, (int16)(M2DP_HALF_T - 1) - kq, mirrored);
    vstore16(convert_uchar16(ring * M2DP_T + sector), 0, codes + plane * n_pad + base);
  }
}

// Pass 3b: counts the codes of one chunk of points for one plane in private 16-bit histograms (four
// interleaved, so that increments of one bin do not wait on each other); global size (chunks, planes).
// partial[(chunk * planes + plane) * l*t + ring * t + sector] = count.
__kernel void m2dp_count(__global const uchar* codes, const int n, const int n_pad, __global uint* partial) {
  const int chunk = (int)get_global_id(0);
  const int plane = (int)get_global_id(1);
  const int begin = chunk * M2DP_CHUNK;
  const int end = min(n, begin + M2DP_CHUNK);
  __global const uchar* c = codes + plane * n_pad;
  uint total[M2DP_LT];
  for (int b = 0; b < M2DP_LT; ++b) total[b] = 0u;
  ushort hist[4][M2DP_LT];
  for (int base = begin; base < end; base += M2DP_SUBBLOCK) {
    const int m = min(M2DP_SUBBLOCK, end - base);
    for (int b = 0; b < M2DP_LT; ++b) hist[0][b] = hist[1][b] = hist[2][b] = hist[3][b] = (ushort)0;
    int i = base;
    for (; i + 4 <= base + m; i += 4) {
      const uchar4 q = vload4(0, c + i);
      hist[0][q.s0]++;
      hist[1][q.s1]++;
      hist[2][q.s2]++;
      hist[3][q.s3]++;
    }
    for (; i < base + m; ++i) hist[0][c[i]]++;
    for (int b = 0; b < M2DP_LT; ++b) total[b] += (uint)hist[0][b] + hist[1][b] + hist[2][b] + hist[3][b];
  }
  __global uint* out = partial + (chunk * M2DP_NPLANES + plane) * M2DP_LT;
  for (int b = 0; b < M2DP_LT; ++b) out[b] = total[b];
}

// Pass 4: the signature matrix A (planes x l*t) as the sum of the per-chunk partial histograms.
__kernel void m2dp_reduce(__global const uint* partial, const int num_chunks, __global uint* signature) {
  const int g = (int)get_global_id(0);
  uint s = 0u;
  for (int c = 0; c < num_chunks; ++c) s += partial[c * (M2DP_NPLANES * M2DP_LT) + g];
  signature[g] = s;
}
