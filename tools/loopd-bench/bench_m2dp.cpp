// loopd-bench m2dp: milliseconds per M2DP descriptor (median / p95 over >= 20 runs after a warm-up) and peak memory,
// on synthetic clouds of N points or on given scan files; optionally the DescriptorStore k-NN time.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <iostream>
#include <random>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/stopwatch.hpp"
#include "loopd/descriptor/m2dp.hpp"
#include "loopd/io/cloud_file.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;

namespace {

/// A street-like synthetic cloud: ground disc, two facades, poles; deterministic for the seed.
std::vector<Eigen::Vector3f> synthetic_cloud(int n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::normal_distribution<float> noise(0.f, 0.02f);
  std::vector<Eigen::Vector3f> pts;
  pts.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const float r = u(rng);
    if (r < 0.5f) {  // ground, denser near the sensor
      const float range = 3.f + 60.f * u(rng) * u(rng), a = 6.2831853f * u(rng);
      pts.emplace_back(range * std::cos(a), range * std::sin(a), -1.8f + noise(rng));
    } else if (r < 0.85f) {  // facades at y = +-8 m
      const float side = u(rng) < 0.6f ? 8.f : -9.f;
      pts.emplace_back(-50.f + 100.f * u(rng), side + noise(rng), -1.8f + 12.f * u(rng) * (0.5f + 0.5f * std::sin(0.3f * static_cast<float>(i % 7))));
    } else {  // poles and clutter
      const int k = static_cast<int>(u(rng) * 12.f);
      pts.emplace_back(-40.f + 7.f * k + noise(rng), (k % 2 ? 6.f : -7.f) + noise(rng), -1.8f + 5.f * u(rng));
    }
  }
  return pts;
}

}  // namespace

/// @brief ms of DescriptorStore::knn (k = 10, every other id allowed) among store_size random descriptors.
static tools::Summary time_knn(const Eigen::VectorXf& query, int store_size, int runs) {
  DescriptorStore store;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (int i = 0; i < store_size; ++i) {
    Eigen::VectorXf d(192);
    for (int j = 0; j < 192; ++j) d(j) = u(rng);
    d.head(64).normalize();
    d.tail(128).normalize();
    store.add(i, d);
  }
  std::vector<double> knn_ms;
  for (int r = 0; r < std::max(runs, 20); ++r) {
    Stopwatch sw;
    const auto nn = store.knn(query, 10, [](std::int64_t id) { return id % 2 == 0; });
    knn_ms.push_back(sw.ms());
  }
  return tools::summarize(knn_ms);
}

int run_bench_m2dp(int argc, char** argv) {
  CLI::App app("loopd-bench m2dp: ms per M2DP descriptor", "loopd-bench m2dp");
  int points = 120000, runs = 20, warmup = 3, store_size = 0, max_points = 0, device = -1;
  std::vector<std::string> files;
  std::string backend_name = "opencl", frame_name = "gravity";
  bool json = false;
  app.add_option("--points", points, "synthetic cloud size (when no FILE is given)");
  app.add_option("files", files, "scan files (.bin/.pcd/.ply); each is described `--runs` times");
  app.add_option("--backend", backend_name, "cpu | opencl | auto")->check(CLI::IsMember({"cpu", "opencl", "auto"}));
  app.add_option("--frame", frame_name, "pca | gravity")->check(CLI::IsMember({"pca", "gravity"}));
  app.add_option("--runs", runs, "timed runs (>= 20 recommended)");
  app.add_option("--warmup", warmup, "untimed runs first");
  app.add_option("--max-points", max_points, "M2dpConfig::max_points (stride subsampling, 0 = all)");
  app.add_option("--device", device, "OpenCL device index (-1: first GPU, else first device)");
  app.add_option("--store", store_size, "also time DescriptorStore::knn (k=10) among this many random descriptors");
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  M2dpConfig config;
  config.backend = *backend_from_string(backend_name);
  config.frame = *frame_from_string(frame_name);
  config.max_points = max_points;
  config.opencl_device = device;
  const M2dp m2dp(config);

  std::vector<std::vector<Eigen::Vector3f>> clouds;
  if (files.empty()) {
    clouds.push_back(synthetic_cloud(points, 42));
  } else {
    for (const auto& f : files) {
      const CloudFile read = read_cloud_file(f);
      if (!read.ok) {
        std::cerr << "loopd-bench m2dp: " << read.error << "\n";
        return tools::kExitUsage;
      }
      clouds.push_back(remove_non_finite(read.cloud).points);
    }
  }
  for (int w = 0; w < warmup; ++w) m2dp.compute(clouds[static_cast<std::size_t>(w) % clouds.size()]);
  std::vector<double> ms;
  std::size_t total_points = 0;
  tools::Progress progress("m2dp", static_cast<std::int64_t>(runs) * static_cast<std::int64_t>(clouds.size()), !json);
  for (int r = 0; r < runs; ++r)
    for (const auto& c : clouds) {
      Stopwatch sw;
      const M2dpResult res = m2dp.compute(c);
      ms.push_back(sw.ms());
      total_points += c.size();
      if (!res.ok) {
        std::cerr << "loopd-bench m2dp: descriptor failed: " << res.error << "\n";
        return 1;
      }
      progress.update(static_cast<std::int64_t>(ms.size()));
    }
  progress.finish();
  const tools::Summary s = tools::summarize(ms);
  const double mean_points = static_cast<double>(total_points) / static_cast<double>(ms.size());

  tools::Summary knn;
  if (store_size > 0) knn = time_knn(m2dp.compute(clouds.front()).descriptor, store_size, runs);
  const double knn_median = knn.median, knn_p95 = knn.p95;

  const std::string backend_used = to_string(m2dp.backend());
  if (json) {
    nlohmann::json j = {{"median_ms", s.median},
                        {"p95_ms", s.p95},
                        {"max_ms", s.max},
                        {"points", mean_points},
                        {"runs", s.count},
                        {"backend", backend_used},
                        {"device", m2dp.device_name()},
                        {"frame", frame_name},
                        {"max_points", max_points},
                        {"peak_rss_bytes", tools::peak_rss_bytes()}};
    if (store_size > 0) {
      j["store_size"] = store_size;
      j["knn_median_ms"] = knn_median;
      j["knn_p95_ms"] = knn_p95;
    }
    tools::print_json_line(j);
  } else {
    tools::Table t({"backend", "device", "frame", "points", "runs", "median ms", "p95 ms", "peak MB"});
    t.add({backend_used, m2dp.device_name(), frame_name, tools::fmt(mean_points, 0), std::to_string(s.count), tools::fmt(s.median), tools::fmt(s.p95),
           tools::fmt(static_cast<double>(tools::peak_rss_bytes()) / 1e6, 1)});
    std::cout << t.str();
    if (store_size > 0)
      std::cout << "DescriptorStore knn k=10 among " << store_size << ": median " << tools::fmt(knn_median) << " ms, p95 " << tools::fmt(knn_p95)
                << " ms\n";
  }
  return 0;
}
