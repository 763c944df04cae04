#include <iostream>
#include <loopd/loop_event_t.hpp>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/correction/loop_corrector.hpp"
#include "loopd/descriptor/m2dp.hpp"
#include "loopd/store/map_store.hpp"

int main() {
  loopd::PointCloud cloud;
  for (int i = 0; i < 1000; ++i) cloud.points.emplace_back(static_cast<float>(i % 10), static_cast<float>(i / 10 % 10), static_cast<float>(i / 100));
  const loopd::PointCloud down = loopd::voxel_downsample(cloud, 2.0);
  loopd::M2dpConfig config;
  config.backend = loopd::Backend::kCpu;
  const loopd::M2dpResult d = loopd::M2dp(config).compute(cloud);
  loopd::loop_event_t event{};
  // The store's back ends register themselves: the installed package links them whole (loopd_store_backends).
  loopd::MapStoreConfig map;
  map.uri = "sqlite::memory:";
  const loopd::OpenedMapStore opened = loopd::open_map_store(map);
  std::cout << "voxels " << down.size() << " descriptor " << d.descriptor.size() << " event " << event.getEncodedSize() << " map stores "
            << loopd::map_store_schemes() << (opened.status.ok() ? "" : " (" + opened.status.message + ")") << "\n";
  return down.size() == 125 && d.ok && d.descriptor.size() == 192 && opened.status.ok() ? 0 : 1;
}
