/* Constants shared by the M2DP host code (src/loopd/descriptor) and kernels/m2dp.cl.
 * Plain C preprocessor only: the host includes this file, and the OpenCL backend prepends its
 * text to m2dp.cl before building the program. Per-config sizes (l, t) are passed to the
 * kernel compiler as -D M2DP_L=.. -D M2DP_T=.. so the binning loops unroll. */
#ifndef LOOPD_M2DP_SHARED_H
#define LOOPD_M2DP_SHARED_H

/* Points per work-item (chunk) in the moment, extent and binning kernels. Large enough that the
 * per-chunk partial histograms stay small (ceil(N / chunk) x planes x bins), small enough to give
 * both cores many independent work-items (120k points -> 15 chunks x 64 planes = 960). */
#define M2DP_CHUNK 8192

/* Work-group size of the code kernel (m2dp_codes), each work-item M2DP_VEC points: 512 points per group. */
#define M2DP_WG 32

/* Binned points per work-item of m2dp_codes (float8 lanes). */
#define M2DP_VEC 16

/* Points counted at once inside a counting work-item (m2dp_count): its 16-bit histograms cannot overflow. */
#define M2DP_SUBBLOCK 4096

/* Floats per projection plane in the plane table: e1 (3), -c.e1, e2 (3), -c.e2, where e1, e2 are
 * the in-plane axes expressed in the input (sensor) frame and c the centroid, so a point p
 * projects to u = e1.p - c.e1, v = e2.p - c.e2 without a separate centring pass. */
#define M2DP_PLANE_STRIDE 8

/* Floats per chunk written by the moments kernel: count, sum x, y, z, sum xx, xy, xz, yy, yz, zz
 * (of the shifted coordinates), padded. */
#define M2DP_MOMENT_STRIDE 12

/* Floats per chunk written by the extent kernel: max squared distance to the centroid, sums of
 * the cubed coordinates along the three sign axes (third moments, for the axis signs), the centred
 * second moments t0t0, t0t1, t0t2, t1t1, t1t2, t2t2 and first moments t0, t1, t2 in the pass-1 PCA
 * axes (to refine the centroid and axes, and for accurate degeneracy checks), padded. */
#define M2DP_EXTENT_STRIDE 16

/* Floats of the frame buffer of the extent kernel: centroid (3), PCA axes (9, rows), sign axes (9). */
#define M2DP_FRAME_FLOATS 21

/* Upper bounds that keep the private histogram of a binning work-item small. */
#define M2DP_MAX_RINGS 32
#define M2DP_MAX_SECTORS 64
#define M2DP_MAX_BINS 256

#endif
