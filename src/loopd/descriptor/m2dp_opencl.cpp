// M2DP OpenCL backend, host side (kernels in kernels/m2dp.cl). One program built at construction,
// buffers kept and grown across scans, one in-order queue guarded by a mutex (thread-safe compute()).
// Per scan: upload, moments kernel -> 3x3 frame on the host, extent kernel -> ring radius and axis
// signs, code kernel (one work-item per point, all planes), count kernel (per chunk and plane), reduce kernel, one
// read of the 64 x 128 matrix.
#ifdef LOOPD_WITH_OPENCL
#include <CL/cl.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <mutex>
#include <utility>

#include "../../../kernels/m2dp_shared.h"
#include "loopd/descriptor/m2dp_internal.hpp"
#include "loopd/opencl/kernel_sources.hpp"
#include "loopd/opencl/opencl_device.hpp"

namespace loopd::detail {

namespace {

struct Buffer {
  cl_mem mem = nullptr;
  std::size_t bytes = 0;
};

/// Outcome of a sequence of OpenCL calls: the first that failed (`what`) and its error code.
struct ClStep {
  const char* what = "";
  cl_int err = CL_SUCCESS;
  bool ok() const { return err == CL_SUCCESS; }
};

/// Launch shape of pass 3 (binning): with max_points only every stride-th point is binned.
struct BinningLaunch {
  int stride = 1;      ///< binning_stride(N, max_points)
  int n_bin = 0;       ///< points binned
  int n_pad = 0;       ///< n_bin rounded up to whole work-groups of M2DP_WG x M2DP_VEC points
  int bin_chunks = 0;  ///< M2DP_CHUNK-point chunks of the binned points
};

BinningLaunch binning_launch(std::size_t num_points, int n, int max_points) {
  BinningLaunch b;
  b.stride = binning_stride(num_points, max_points);
  b.n_bin = (n + b.stride - 1) / b.stride;
  constexpr int kGroupPoints = M2DP_WG * M2DP_VEC;
  b.n_pad = (b.n_bin + kGroupPoints - 1) / kGroupPoints * kGroupPoints;
  b.bin_chunks = (b.n_bin + M2DP_CHUNK - 1) / M2DP_CHUNK;
  return b;
}

/// Pass 1 on the host: the per-chunk moments summed in double; centroid (shifted coordinates) and covariance.
FirstMoments combine_first_moments(const std::vector<float>& host_moments, std::size_t chunks) {
  double count = 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_sq = Eigen::Matrix3d::Zero();
  for (std::size_t c = 0; c < chunks; ++c) {
    const float* m = host_moments.data() + c * M2DP_MOMENT_STRIDE;
    count += m[0];
    sum += Eigen::Vector3d(m[1], m[2], m[3]);
    sum_sq(0, 0) += m[4];
    sum_sq(0, 1) += m[5];
    sum_sq(0, 2) += m[6];
    sum_sq(1, 1) += m[7];
    sum_sq(1, 2) += m[8];
    sum_sq(2, 2) += m[9];
  }
  sum_sq(1, 0) = sum_sq(0, 1);
  sum_sq(2, 0) = sum_sq(0, 2);
  sum_sq(2, 1) = sum_sq(1, 2);
  FirstMoments first;
  first.count = count;
  first.centroid = sum / count;  // shifted coordinates
  first.covariance = sum_sq / count - first.centroid * first.centroid.transpose();
  return first;
}

/// Kernel input of pass 2: centroid, PCA axes and sign axes (rows), as floats.
void pack_frame(const Eigen::Vector3d& centroid, const Eigen::Matrix3d& pca, const Eigen::Matrix3d& sign_axes, float (&frame)[M2DP_FRAME_FLOATS]) {
  for (int i = 0; i < 3; ++i) frame[i] = static_cast<float>(centroid(i));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      frame[3 + 3 * r + c] = static_cast<float>(pca(r, c));
      frame[12 + 3 * r + c] = static_cast<float>(sign_axes(r, c));
    }
}

/// Pass 2 on the host: the per-chunk extent and moments summed in double.
SecondMoments combine_second_moments(const std::vector<float>& host_extent, std::size_t chunks) {
  SecondMoments second;
  for (std::size_t c = 0; c < chunks; ++c) {
    const float* e = host_extent.data() + c * M2DP_EXTENT_STRIDE;
    second.max_r2 = std::max(second.max_r2, static_cast<double>(e[0]));
    if (!std::isfinite(e[0])) second.max_r2 = e[0];
    second.third += Eigen::Vector3d(e[1], e[2], e[3]);
    second.second(0, 0) += e[4];
    second.second(0, 1) += e[5];
    second.second(0, 2) += e[6];
    second.second(1, 1) += e[7];
    second.second(1, 2) += e[8];
    second.second(2, 2) += e[9];
    second.first += Eigen::Vector3d(e[10], e[11], e[12]);
  }
  second.second(1, 0) = second.second(0, 1);
  second.second(2, 0) = second.second(0, 2);
  second.second(2, 1) = second.second(1, 2);
  return second;
}

/// A result that failed at an OpenCL call: no descriptor, the call and its error code in `error`.
M2dpResult failed(M2dpResult result, const ClStep& step) {
  result.ok = false;
  result.error = std::string("OpenCL ") + step.what + ": " + opencl_error_string(step.err);
  result.descriptor.resize(0);
  return result;
}

}  // namespace

struct M2dpOpenCl::State {
  std::mutex mutex;
  cl_context context = nullptr;
  cl_command_queue queue = nullptr;
  cl_program program = nullptr;
  cl_kernel k_moments = nullptr, k_extent = nullptr, k_codes = nullptr, k_count = nullptr, k_reduce = nullptr;
  Buffer xyz, xs, ys, zs, moments, extent, frame, planes, params, codes, partial, signature;
  std::vector<float> host_moments, host_extent;
  std::vector<std::uint32_t> host_signature;

  ~State() {
    for (Buffer* b : {&xyz, &xs, &ys, &zs, &moments, &extent, &frame, &planes, &params, &codes, &partial, &signature})
      if (b->mem) clReleaseMemObject(b->mem);
    for (cl_kernel k : {k_moments, k_extent, k_codes, k_count, k_reduce})
      if (k) clReleaseKernel(k);
    if (program) clReleaseProgram(program);
    if (queue) clReleaseCommandQueue(queue);
    if (context) clReleaseContext(context);
  }

  /// Grows `b` to at least `bytes` (never shrinks, so steady-state scans allocate nothing).
  cl_int ensure(Buffer& b, std::size_t bytes, cl_mem_flags flags) {
    if (b.bytes >= bytes && b.mem) return CL_SUCCESS;
    if (b.mem) clReleaseMemObject(b.mem);
    const std::size_t alloc = std::max<std::size_t>(bytes + bytes / 4, 64);
    cl_int err = CL_SUCCESS;
    b.mem = clCreateBuffer(context, flags, alloc, nullptr, &err);
    b.bytes = err == CL_SUCCESS ? alloc : 0;
    return err;
  }

  // The steps of compute(), in order; each returns the first OpenCL call that failed, if any.
  ClStep ensure_scan_buffers(int n, int num_chunks, std::size_t num_planes, std::size_t num_bins);
  ClStep run_moments(const std::vector<Eigen::Vector3f>& points, int n, const Eigen::Vector3f& shift, std::size_t chunks);
  ClStep run_extent(const float (&frame_floats)[M2DP_FRAME_FLOATS], int n, std::size_t chunks);
  ClStep upload_planes(const std::vector<float>& plane_floats, const std::vector<float>& param_floats);
  ClStep run_binning(const BinningLaunch& launch, std::size_t num_planes, std::size_t num_bins);
};

namespace {
template <typename T>
cl_int set_arg(cl_kernel k, cl_uint i, const T& v) {
  return clSetKernelArg(k, i, sizeof(T), &v);
}
}  // namespace

M2dpOpenCl::M2dpOpenCl(const M2dpConfig& config) : config_(config), state_(std::make_unique<State>()) {
  const OpenClDevicePick pick = pick_opencl_device(config.opencl_device);
  if (!pick.ok) {
    error_ = pick.error;
    return;
  }
  const OpenClDeviceInfo& device = pick.device;
  device_name_ = device.name + " (" + device.platform + ")";
  cl_device_id id = static_cast<cl_device_id>(device.id);
  cl_int err = CL_SUCCESS;
  State& s = *state_;
  s.context = clCreateContext(nullptr, 1, &id, nullptr, nullptr, &err);
  if (err != CL_SUCCESS) {
    error_ = "clCreateContext: " + opencl_error_string(err);
    return;
  }
  s.queue = clCreateCommandQueue(s.context, id, 0, &err);
  if (err != CL_SUCCESS) {
    error_ = "clCreateCommandQueue: " + opencl_error_string(err);
    return;
  }
  // m2dp_shared.h is prepended (no include paths at run time); l, t and p*q become compile-time constants.
  const std::string source = kernel_source("m2dp_shared.h") + "\n" + kernel_source("m2dp.cl");
  if (source.size() < 100) {
    error_ = "kernel sources m2dp_shared.h / m2dp.cl were not embedded";
    return;
  }
  const char* text = source.c_str();
  const std::size_t length = source.size();
  s.program = clCreateProgramWithSource(s.context, 1, &text, &length, &err);
  if (err != CL_SUCCESS) {
    error_ = "clCreateProgramWithSource: " + opencl_error_string(err);
    return;
  }
  const std::string options = "-cl-std=CL1.2 -D M2DP_L=" + std::to_string(config.num_rings_l) + " -D M2DP_T=" + std::to_string(config.num_sectors_t) +
                              " -D M2DP_NPLANES=" + std::to_string(config.num_planes());
  err = clBuildProgram(s.program, 1, &id, options.c_str(), nullptr, nullptr);
  if (err != CL_SUCCESS) {
    std::size_t n = 0;
    clGetProgramBuildInfo(s.program, id, CL_PROGRAM_BUILD_LOG, 0, nullptr, &n);
    std::string log(n, '\0');
    clGetProgramBuildInfo(s.program, id, CL_PROGRAM_BUILD_LOG, n, log.data(), nullptr);
    error_ = "clBuildProgram: " + opencl_error_string(err) + ": " + log.substr(0, 2000);
    return;
  }
  const std::pair<cl_kernel*, const char*> kernels[] = {{&s.k_moments, "m2dp_moments"},
                                                        {&s.k_extent, "m2dp_extent"},
                                                        {&s.k_codes, "m2dp_codes"},
                                                        {&s.k_count, "m2dp_count"},
                                                        {&s.k_reduce, "m2dp_reduce"}};
  for (const auto& [k, name] : kernels) {
    *k = clCreateKernel(s.program, name, &err);
    if (err != CL_SUCCESS) {
      error_ = std::string("clCreateKernel ") + name + ": " + opencl_error_string(err);
      return;
    }
  }
  const std::size_t num_planes = static_cast<std::size_t>(config.num_planes()), num_bins = static_cast<std::size_t>(config.num_bins());
  if ((err = s.ensure(s.frame, M2DP_FRAME_FLOATS * sizeof(float), CL_MEM_READ_ONLY)) != CL_SUCCESS ||
      (err = s.ensure(s.planes, num_planes * M2DP_PLANE_STRIDE * sizeof(float), CL_MEM_READ_ONLY)) != CL_SUCCESS ||
      (err = s.ensure(s.params, (M2DP_MAX_RINGS + M2DP_MAX_SECTORS) * sizeof(float), CL_MEM_READ_ONLY)) != CL_SUCCESS ||
      (err = s.ensure(s.signature, num_planes * num_bins * sizeof(std::uint32_t), CL_MEM_WRITE_ONLY)) != CL_SUCCESS) {
    error_ = "clCreateBuffer: " + opencl_error_string(err);
    return;
  }
}

M2dpOpenCl::~M2dpOpenCl() = default;

ClStep M2dpOpenCl::State::ensure_scan_buffers(int n, int num_chunks, std::size_t num_planes, std::size_t num_bins) {
  cl_int err = CL_SUCCESS;
  if ((err = ensure(xyz, static_cast<std::size_t>(n) * 3 * sizeof(float), CL_MEM_READ_ONLY)) != CL_SUCCESS ||
      (err = ensure(xs, static_cast<std::size_t>(n) * sizeof(float), CL_MEM_READ_WRITE)) != CL_SUCCESS ||
      (err = ensure(ys, static_cast<std::size_t>(n) * sizeof(float), CL_MEM_READ_WRITE)) != CL_SUCCESS ||
      (err = ensure(zs, static_cast<std::size_t>(n) * sizeof(float), CL_MEM_READ_WRITE)) != CL_SUCCESS ||
      (err = ensure(moments, static_cast<std::size_t>(num_chunks) * M2DP_MOMENT_STRIDE * sizeof(float), CL_MEM_READ_WRITE)) != CL_SUCCESS ||
      (err = ensure(extent, static_cast<std::size_t>(num_chunks) * M2DP_EXTENT_STRIDE * sizeof(float), CL_MEM_READ_WRITE)) != CL_SUCCESS ||
      (err = ensure(partial, static_cast<std::size_t>(num_chunks) * num_planes * num_bins * sizeof(std::uint32_t), CL_MEM_READ_WRITE)) != CL_SUCCESS)
    return {"buffer", err};
  return {};
}

ClStep M2dpOpenCl::State::run_moments(const std::vector<Eigen::Vector3f>& points, int n, const Eigen::Vector3f& shift, std::size_t chunks) {
  const std::size_t one = 1;
  cl_int err = CL_SUCCESS;
  if ((err = clEnqueueWriteBuffer(queue, xyz.mem, CL_FALSE, 0, static_cast<std::size_t>(n) * 3 * sizeof(float), points.data(), 0, nullptr,
                                  nullptr)) != CL_SUCCESS)
    return {"upload", err};
  set_arg(k_moments, 0, xyz.mem);
  set_arg(k_moments, 1, n);
  set_arg(k_moments, 2, shift.x());
  set_arg(k_moments, 3, shift.y());
  set_arg(k_moments, 4, shift.z());
  set_arg(k_moments, 5, xs.mem);
  set_arg(k_moments, 6, ys.mem);
  set_arg(k_moments, 7, zs.mem);
  set_arg(k_moments, 8, moments.mem);
  if ((err = clEnqueueNDRangeKernel(queue, k_moments, 1, nullptr, &chunks, &one, 0, nullptr, nullptr)) != CL_SUCCESS) return {"m2dp_moments", err};
  host_moments.resize(chunks * M2DP_MOMENT_STRIDE);
  if ((err = clEnqueueReadBuffer(queue, moments.mem, CL_TRUE, 0, host_moments.size() * sizeof(float), host_moments.data(), 0, nullptr, nullptr)) !=
      CL_SUCCESS)
    return {"read moments", err};
  return {};
}

ClStep M2dpOpenCl::State::run_extent(const float (&frame_floats)[M2DP_FRAME_FLOATS], int n, std::size_t chunks) {
  const std::size_t one = 1;
  cl_int err = CL_SUCCESS;
  if ((err = clEnqueueWriteBuffer(queue, frame.mem, CL_FALSE, 0, sizeof(frame_floats), frame_floats, 0, nullptr, nullptr)) != CL_SUCCESS)
    return {"upload frame", err};
  set_arg(k_extent, 0, xs.mem);
  set_arg(k_extent, 1, ys.mem);
  set_arg(k_extent, 2, zs.mem);
  set_arg(k_extent, 3, n);
  set_arg(k_extent, 4, frame.mem);
  set_arg(k_extent, 5, extent.mem);
  if ((err = clEnqueueNDRangeKernel(queue, k_extent, 1, nullptr, &chunks, &one, 0, nullptr, nullptr)) != CL_SUCCESS) return {"m2dp_extent", err};
  host_extent.resize(chunks * M2DP_EXTENT_STRIDE);
  if ((err = clEnqueueReadBuffer(queue, extent.mem, CL_TRUE, 0, host_extent.size() * sizeof(float), host_extent.data(), 0, nullptr, nullptr)) !=
      CL_SUCCESS)
    return {"read extent", err};
  return {};
}

ClStep M2dpOpenCl::State::upload_planes(const std::vector<float>& plane_floats, const std::vector<float>& param_floats) {
  cl_int err = CL_SUCCESS;
  if ((err = clEnqueueWriteBuffer(queue, planes.mem, CL_FALSE, 0, plane_floats.size() * sizeof(float), plane_floats.data(), 0, nullptr, nullptr)) !=
          CL_SUCCESS ||
      (err = clEnqueueWriteBuffer(queue, params.mem, CL_FALSE, 0, param_floats.size() * sizeof(float), param_floats.data(), 0, nullptr, nullptr)) !=
          CL_SUCCESS)
    return {"upload planes", err};
  return {};
}

ClStep M2dpOpenCl::State::run_binning(const BinningLaunch& launch, std::size_t num_planes, std::size_t num_bins) {
  cl_int err = CL_SUCCESS;
  if ((err = ensure(codes, num_planes * static_cast<std::size_t>(launch.n_pad), CL_MEM_READ_WRITE)) != CL_SUCCESS) return {"buffer", err};
  set_arg(k_codes, 0, xs.mem);
  set_arg(k_codes, 1, ys.mem);
  set_arg(k_codes, 2, zs.mem);
  set_arg(k_codes, 3, launch.n_bin);
  set_arg(k_codes, 4, launch.stride);
  set_arg(k_codes, 5, planes.mem);
  set_arg(k_codes, 6, params.mem);
  set_arg(k_codes, 7, codes.mem);
  set_arg(k_codes, 8, launch.n_pad);
  const std::size_t codes_global = static_cast<std::size_t>(launch.n_pad / M2DP_VEC), codes_local = M2DP_WG;
  if ((err = clEnqueueNDRangeKernel(queue, k_codes, 1, nullptr, &codes_global, &codes_local, 0, nullptr, nullptr)) != CL_SUCCESS)
    return {"m2dp_codes", err};
  set_arg(k_count, 0, codes.mem);
  set_arg(k_count, 1, launch.n_bin);
  set_arg(k_count, 2, launch.n_pad);
  set_arg(k_count, 3, partial.mem);
  const std::size_t count_global[2] = {static_cast<std::size_t>(launch.bin_chunks), num_planes};
  const std::size_t count_local[2] = {1, 1};
  if ((err = clEnqueueNDRangeKernel(queue, k_count, 2, nullptr, count_global, count_local, 0, nullptr, nullptr)) != CL_SUCCESS)
    return {"m2dp_count", err};
  const int chunks_arg = launch.bin_chunks;
  set_arg(k_reduce, 0, partial.mem);
  set_arg(k_reduce, 1, chunks_arg);
  set_arg(k_reduce, 2, signature.mem);
  const std::size_t reduce_global = num_planes * num_bins;
  if ((err = clEnqueueNDRangeKernel(queue, k_reduce, 1, nullptr, &reduce_global, nullptr, 0, nullptr, nullptr)) != CL_SUCCESS)
    return {"m2dp_reduce", err};
  host_signature.resize(num_planes * num_bins);
  if ((err = clEnqueueReadBuffer(queue, signature.mem, CL_TRUE, 0, host_signature.size() * sizeof(std::uint32_t), host_signature.data(), 0, nullptr,
                                 nullptr)) != CL_SUCCESS)
    return {"read signature", err};
  return {};
}

M2dpResult M2dpOpenCl::compute(const std::vector<Eigen::Vector3f>& points) {
  M2dpResult result;
  result.backend = Backend::kOpenCl;
  result.num_points = static_cast<int>(std::min<std::size_t>(points.size(), INT_MAX));
  if (points.size() < 3) {
    result.error = check_first(FirstMoments{static_cast<double>(points.size())});
    return result;
  }
  if (points.size() > static_cast<std::size_t>(INT_MAX / 3)) {
    result.error = "too many points for the OpenCL backend";
    return result;
  }
  std::lock_guard<std::mutex> lock(state_->mutex);
  State& s = *state_;
  const int n = static_cast<int>(points.size());
  const int num_chunks = (n + M2DP_CHUNK - 1) / M2DP_CHUNK;
  const std::size_t num_planes = static_cast<std::size_t>(config_.num_planes()), num_bins = static_cast<std::size_t>(config_.num_bins());
  if (const ClStep st = s.ensure_scan_buffers(n, num_chunks, num_planes, num_bins); !st.ok()) return failed(std::move(result), st);

  // Shift by the first point so that float sums in the kernel stay accurate far from the origin.
  Eigen::Vector3f shift = points.front();
  if (!shift.allFinite()) shift.setZero();
  const std::size_t chunks = static_cast<std::size_t>(num_chunks);

  // Pass 1: moments (reduction per chunk), combined in double on the host.
  if (const ClStep st = s.run_moments(points, n, shift, chunks); !st.ok()) return failed(std::move(result), st);
  const FirstMoments first = combine_first_moments(s.host_moments, chunks);
  if (std::string e = check_first(first); !e.empty()) {
    result.error = e;
    return result;
  }
  const Eigen::Matrix3d pca = pca_axes(first.covariance);
  const Eigen::Matrix3d sign_axes = frame_axes(first.covariance, config_.frame);

  // Pass 2: extent, third moments along the sign axes, centred moments in the PCA axes.
  float frame[M2DP_FRAME_FLOATS];
  pack_frame(first.centroid, pca, sign_axes, frame);
  if (const ClStep st = s.run_extent(frame, n, chunks); !st.ok()) return failed(std::move(result), st);
  const Frame f = finish_frame(first, pca, sign_axes, combine_second_moments(s.host_extent, chunks), config_.frame);
  if (!f.error.empty()) {
    result.error = f.error;
    return result;
  }
  result.axes = f.axes;
  result.centroid = f.centroid + shift.cast<double>();
  result.max_radius = std::sqrt(f.max_r2);

  // Pass 3: bin codes of all planes x all points in one launch, counts per chunk and plane in a second, then the
  // per-chunk histograms summed on the device.
  const std::vector<float> planes = plane_table(config_, f.axes, f.centroid);
  const std::vector<float> params = bin_params(config_, f.max_r2);
  if (const ClStep st = s.upload_planes(planes, params); !st.ok()) return failed(std::move(result), st);
  // max_points: only every stride-th point is binned (the moment and extent passes above used all points).
  const BinningLaunch launch = binning_launch(points.size(), n, config_.max_points);
  result.num_points = launch.n_bin;
  if (const ClStep st = s.run_binning(launch, num_planes, num_bins); !st.ok()) return failed(std::move(result), st);

  descriptor_from_signature(s.host_signature, config_, &result);
  return result;
}

}  // namespace loopd::detail
#endif  // LOOPD_WITH_OPENCL
