// M2DP under max_points stride subsampling: distance between the full descriptor and the subsampled one on real
// KITTI HDL-64E scans and on simulated HDL-64E scans, against the distances that matter for loop detection
// (revisits ~0.05, nearest other place ~0.21 on KITTI). The signature matrix only counts points per bin, so a
// uniform subsample scales every count by about the same factor and its singular vectors barely move.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cstdio>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/descriptor/m2dp.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/sim/drive.hpp"
#include "support/data_dir.hpp"

using namespace loopd;

namespace {

constexpr int kSizes[] = {10000, 20000, 30000, 60000};

/// Per size: the largest and the median full-vs-subsampled distance over the clouds.
void measure(const std::vector<std::vector<Eigen::Vector3f>>& clouds, const char* label, std::vector<float>* max_err) {
  M2dpConfig full_config;
  full_config.backend = Backend::kCpu;
  full_config.max_points = 0;
  const M2dp full(full_config);
  std::vector<Eigen::VectorXf> ref;
  for (const auto& c : clouds) {
    const M2dpResult r = full.compute(c);
    REQUIRE(r.ok);
    ref.push_back(r.descriptor);
  }
  max_err->clear();
  for (int size : kSizes) {
    M2dpConfig config = full_config;
    config.max_points = size;
    const M2dp sub(config);
    std::vector<float> d;
    for (std::size_t i = 0; i < clouds.size(); ++i) {
      const M2dpResult r = sub.compute(clouds[i]);
      REQUIRE(r.ok);
      d.push_back(descriptor_distance(r.descriptor, ref[i]));
    }
    std::sort(d.begin(), d.end());
    std::printf("M2DP subsample %s: max_points %6d  median %.4f  max %.4f  (%zu clouds)\n", label, size, d[d.size() / 2], d.back(), d.size());
    max_err->push_back(d.back());
  }
}

}  // namespace

TEST_CASE("M2DP max_points subsampling stays far below the revisit distance on real KITTI scans", "[m2dp][subsample]") {
  const char* frames[] = {"000000", "000001", "000002", "000003", "000004", "000005", "000015", "000094", "000095", "000198", "000199"};
  std::vector<std::vector<Eigen::Vector3f>> clouds;
  for (const char* f : frames) {
    LOOPD_REQUIRE_DATA(path, std::string("kitti/seq00/") + f + ".bin");
    const CloudFile read = read_cloud_file(path);
    REQUIRE(read.ok);
    clouds.push_back(remove_non_finite(read.cloud).points);
  }
  std::vector<float> max_err;
  measure(clouds, "KITTI", &max_err);
  // 10k, 20k, 30k, 60k points out of ~122k; KITTI revisits are ~0.05 apart.
  CHECK(max_err[2] < 0.01f);  // 30k: the daemon default
  CHECK(max_err[3] < 0.005f);
}

TEST_CASE("M2DP max_points subsampling stays far below the revisit distance on simulated scans", "[m2dp][subsample]") {
  DriveConfig config;
  config.sensor = "hdl64";
  config.num_scans = 200;
  config.seed = 5;
  const Drive drive = make_drive(config);
  std::vector<std::vector<Eigen::Vector3f>> clouds;
  for (int i = 0; i < static_cast<int>(drive.scans.size()); i += 40) clouds.push_back(remove_non_finite(drive.simulate(i, 2)).points);
  std::vector<float> max_err;
  measure(clouds, "sim HDL-64E", &max_err);
  CHECK(max_err[2] < 0.01f);
  CHECK(max_err[3] < 0.005f);
}

TEST_CASE("M2DP max_points: the OpenCL backend bins the same strided points as the CPU reference", "[m2dp][subsample][opencl]") {
  LOOPD_REQUIRE_DATA(path, "kitti/seq00/000094.bin");
  const CloudFile read = read_cloud_file(path);
  REQUIRE(read.ok);
  const std::vector<Eigen::Vector3f> points = remove_non_finite(read.cloud).points;
  M2dpConfig config;
  config.max_points = 30000;
  config.backend = Backend::kCpu;
  const M2dpResult cpu = M2dp(config).compute(points);
  config.backend = Backend::kOpenCl;
  config.log_fallback = true;
  const M2dp cl(config);
  if (cl.backend() != Backend::kOpenCl) {
    WARN("skipped: no OpenCL device");
    return;
  }
  const M2dpResult gpu = cl.compute(points);
  REQUIRE(cpu.ok);
  REQUIRE(gpu.ok);
  CHECK(cpu.num_points == gpu.num_points);
  CHECK(cpu.num_points <= 30000);
  CHECK((cpu.descriptor - gpu.descriptor).cwiseAbs().maxCoeff() <= 1e-4f);
}
