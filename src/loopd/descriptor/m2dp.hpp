#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief Where the descriptor is computed. kAuto: OpenCL when a device exists, else CPU.
enum class Backend { kCpu, kOpenCl, kAuto };

/// @brief Reference frame in which the projection planes are defined.
enum class M2dpFrame {
  kPca,            ///< Paper frame (He 2016; Vlaminck 2019 Sec. 4.1): x, y = first two principal axes, z = third.
  kGravityAligned  ///< z = sensor z (up); x, y = principal axes of the points in the ground plane.
};

std::string to_string(Backend backend);
std::string to_string(M2dpFrame frame);
std::optional<Backend> backend_from_string(const std::string& name);  ///< "cpu", "opencl", "auto"
std::optional<M2dpFrame> frame_from_string(const std::string& name);  ///< "pca", "gravity"

/// @brief M2DP parameters (He et al. 2016, IROS; Vlaminck et al. 2019, Sensors, Sec. 4.1 and 5: l=8, t=16, p=4, q=16).
struct M2dpConfig {
  int num_rings_l = 8;        ///< l: concentric rings per plane, outer radii k^2 r, k = 1..l (Vlaminck 2019 Sec. 4.1)
  int num_sectors_t = 16;     ///< t: sectors per ring over (-pi, pi]; a multiple of 4 (comparison binning per quarter turn)
  int num_azimuths_p = 4;     ///< p: plane azimuths, stride pi/p starting at -pi/2 (He 2016)
  int num_elevations_q = 16;  ///< q: plane elevations, stride pi/(2q) starting at 0 (He 2016)
  /// Frame of the planes. Default kGravityAligned: on the simulated drive and on KITTI revisits it separates
  /// revisits from other places better than the paper's PCA frame, whose in-plane axes flip or swing
  /// between visits when the first two principal values are close (see test_m2dp.cpp and the M2DP report).
  M2dpFrame frame = M2dpFrame::kGravityAligned;
  Backend backend = Backend::kAuto;
  int opencl_device = -1;  ///< index into all OpenCL devices of all platforms; -1: first GPU, else first device
  int num_threads = 0;     ///< CPU backend threads (OpenMP); 0: OpenMP default
  /// Deterministic stride subsampling of the binning: when the cloud has more than this many points, every
  /// ceil(N / max_points)-th point is projected and counted; the frame (centroid, axes, axis signs) and the outer ring
  /// radius still come from all points (cheap O(N) passes; the farthest point and the axes are what a subsample
  /// perturbs most). 0 = bin all points (paper). The singular vectors do not change when all counts are scaled, so
  /// a uniform subsample approximates the full descriptor (measured in test_m2dp_subsample.cpp).
  /// Default 30,000: on the 11 KITTI seq00 scans (~122k points) the descriptor moves by at most 0.0035 (median
  /// 0.0028), on simulated HDL-64E scans by at most 0.0036, against ~0.05 between revisits and ~0.21 to the nearest
  /// other place; binning 30k instead of 122k points is ~4x less work.
  int max_points = 30000;
  bool log_fallback = true;  ///< print one stderr line when kAuto/kOpenCl falls back to the CPU

  int num_planes() const { return num_azimuths_p * num_elevations_q; }
  int num_bins() const { return num_rings_l * num_sectors_t; }
  int descriptor_size() const { return num_planes() + num_bins(); }  ///< p*q + l*t = 192 by default
  std::optional<std::string> validate() const;
};

/// @brief Descriptor of one scan: first left (p*q) then first right (l*t) singular vector of the signature matrix.
struct M2dpResult {
  bool ok = false;
  std::string error;                                   ///< why ok == false
  Eigen::VectorXf descriptor;                          ///< size p*q + l*t; empty when !ok
  Backend backend = Backend::kCpu;                     ///< backend that computed it
  int num_points = 0;                                  ///< points used (after max_points subsampling)
  double max_radius = 0;                               ///< [m] farthest point from the centroid (outer ring radius l^2 r)
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  ///< rows: frame x, y, z axes in the input frame
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< [m] in the input frame
};

namespace detail {
class M2dpOpenCl;
}

/// @brief M2DP global descriptor (He 2016) with a CPU reference and an OpenCL backend.
/// @note compute() is thread-safe. The OpenCL backend serialises scans on one command queue (a mutex);
///       the CPU backend runs concurrently.
class M2dp {
 public:
  /// @throws std::invalid_argument when config.validate() fails, or when Backend::kOpenCl is forced
  ///         with log_fallback == false and no device exists (with log_fallback it falls back to the CPU).
  explicit M2dp(const M2dpConfig& config = {});
  ~M2dp();
  M2dp(const M2dp&) = delete;
  M2dp& operator=(const M2dp&) = delete;

  M2dpResult compute(const PointCloud& cloud) const;
  M2dpResult compute(const std::vector<Eigen::Vector3f>& points) const;

  std::string device_name() const;  ///< OpenCL device name, or "cpu"
  Backend backend() const { return backend_; }
  const M2dpConfig& config() const { return config_; }

 private:
  M2dpConfig config_;
  Backend backend_ = Backend::kCpu;
  std::unique_ptr<detail::M2dpOpenCl> opencl_;
};

/// @brief L2 distance between two descriptors (all 192 values). Infinity when sizes differ.
float descriptor_distance(const Eigen::VectorXf& a, const Eigen::VectorXf& b);

/// @brief Exact k-nearest-neighbour search over stored descriptors.
/// knn() first scans an 8-bit copy of every row (a quarter of the bytes of the floats; per row a scale and the exact
/// norm of its quantisation error), which bounds each true distance from below and above by the triangle
/// inequality; only rows whose lower bound does not exceed the k-th smallest upper bound get their exact float
/// distance. The result equals a brute-force scan (test_descriptor_store.cpp).
/// @note A k-d tree prunes almost nothing on 192-D descriptors. add() and knn() may be called from different
///       threads (a mutex guards the store); `filter` is called on the calling thread only.
class DescriptorStore {
 public:
  void add(std::int64_t id, const Eigen::VectorXf& descriptor);
  /// @brief Up to k (id, distance) pairs, nearest first; ids rejected by `filter` are skipped.
  std::vector<std::pair<std::int64_t, float>> knn(const Eigen::VectorXf& query, int k, const std::function<bool(std::int64_t)>& filter = {}) const;
  std::size_t size() const;
  int dimension() const { return dim_; }

 private:
  mutable std::mutex mutex_;
  int dim_ = 0;
  std::vector<std::int64_t> ids_;
  std::vector<float> data_;         ///< row-major, size() x dim_
  int qdim_ = 0;                    ///< dim_ rounded up to 32 (padding is zero)
  std::vector<std::int8_t> quant_;  ///< row-major, size() x qdim_: round(x / scale)
  std::vector<float> scale_;        ///< per row: max |x| / 127
  std::vector<float> quant_norm2_;  ///< per row: || scale * quant ||^2
  std::vector<float> quant_error_;  ///< per row: || x - scale * quant || (exact, summed in double)
};

}  // namespace loopd
