#include <iostream>
#include <loopd/loop_event_t.hpp>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/correction/loop_corrector.hpp"
#include "loopd/descriptor/m2dp.hpp"

int main() {
  loopd::PointCloud cloud;
  for (int i = 0; i < 1000; ++i) cloud.points.emplace_back(static_cast<float>(i % 10), static_cast<float>(i / 10 % 10), static_cast<float>(i / 100));
  const loopd::PointCloud down = loopd::voxel_downsample(cloud, 2.0);
  loopd::M2dpConfig config;
  config.backend = loopd::Backend::kCpu;
  const loopd::M2dpResult d = loopd::M2dp(config).compute(cloud);
  loopd::loop_event_t event{};
  std::cout << "voxels " << down.size() << " descriptor " << d.descriptor.size() << " event " << event.getEncodedSize() << "\n";
  return down.size() == 125 && d.ok && d.descriptor.size() == 192 ? 0 : 1;
}
