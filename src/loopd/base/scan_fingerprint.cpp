#include "loopd/base/scan_fingerprint.hpp"

#include <algorithm>
#include <cstring>

namespace loopd {
namespace {

constexpr std::uint64_t kFnvOffset = 14695981039346656037ull;
constexpr std::uint64_t kFnvPrime = 1099511628211ull;

void mix(std::uint64_t& h, const void* data, std::size_t n) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ bytes[i]) * kFnvPrime;
}

}  // namespace

std::uint64_t scan_fingerprint(const PointCloud& scan) {
  std::uint64_t h = kFnvOffset;
  const std::uint64_t n = scan.points.size();
  mix(h, &n, sizeof(n));
  if (n > 0) {
    const std::size_t stride = std::max<std::size_t>(1, (n + 4095) / 4096);
    for (std::size_t i = 0; i < n; i += stride) mix(h, scan.points[i].data(), 3 * sizeof(float));
    mix(h, scan.points[n - 1].data(), 3 * sizeof(float));
  }
  return h == 0 ? 1 : h;
}

}  // namespace loopd
