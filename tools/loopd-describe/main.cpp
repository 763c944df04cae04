// loopd-describe FILE: the M2DP descriptor of one scan (KITTI .bin, PCD or PLY).
#include <CLI/CLI.hpp>
#include <iostream>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/stopwatch.hpp"
#include "loopd/descriptor/m2dp.hpp"
#include "loopd/io/cloud_file.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;

int main(int argc, char** argv) {
  CLI::App app("loopd-describe: M2DP descriptor (192 values) of a scan file");
  std::string file, backend_name = "auto", frame_name = "gravity";
  bool json = false;
  int max_points = 0;
  app.add_option("FILE", file, "scan file (.bin KITTI, .pcd, .ply)")->required();
  app.add_option("--backend", backend_name, "cpu | opencl | auto")->check(CLI::IsMember({"cpu", "opencl", "auto"}));
  app.add_option("--frame", frame_name, "pca (paper) | gravity (z up)")->check(CLI::IsMember({"pca", "gravity"}));
  app.add_option("--max-points", max_points, "stride-subsample to at most this many points (0 = all)");
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;

  const CloudFile read = read_cloud_file(file);
  if (!read.ok) {
    std::cerr << "loopd-describe: " << read.error << "\n";
    return loopd::tools::kExitUsage;
  }
  std::size_t removed = 0;
  const PointCloud cloud = remove_non_finite(read.cloud, &removed);
  M2dpConfig config;
  config.backend = *backend_from_string(backend_name);
  config.frame = *frame_from_string(frame_name);
  config.max_points = max_points;
  const M2dp m2dp(config);
  Stopwatch sw;
  const M2dpResult r = m2dp.compute(cloud);
  const double ms = sw.ms();
  if (!r.ok) {
    std::cerr << "loopd-describe: " << r.error << "\n";
    return loopd::tools::kExitUsage;
  }
  if (json) {
    std::vector<float> d(r.descriptor.data(), r.descriptor.data() + r.descriptor.size());
    tools::print_json_line({{"descriptor", d},
                            {"ms", ms},
                            {"backend", to_string(r.backend)},
                            {"device", m2dp.device_name()},
                            {"frame", frame_name},
                            {"points", r.num_points},
                            {"non_finite_removed", removed},
                            {"max_radius", r.max_radius}});
    return 0;
  }
  tools::Table t({"file", "points", "backend", "frame", "max radius m", "ms"});
  t.add({file, std::to_string(r.num_points), to_string(r.backend) + " (" + m2dp.device_name() + ")", frame_name, tools::fmt(r.max_radius, 2),
         tools::fmt(ms)});
  std::cout << t.str() << "descriptor (first left singular vector, " << 64 << " values, then first right, 128 values):\n";
  for (int i = 0; i < r.descriptor.size(); ++i) std::cout << tools::fmt(r.descriptor(i), 5) << (i % 8 == 7 ? "\n" : " ");
  std::cout << "\n";
  return 0;
}
