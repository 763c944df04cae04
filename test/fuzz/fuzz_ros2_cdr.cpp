// ROS 2 messages from CDR (src/loopd/io/ros2_cdr): any bytes through the four decoders bag2lcm uses, then a decoded
// PointCloud2 through decode_pointcloud2. Checks: ok exactly without an error, which names CDR and a field; a cloud's
// data lies inside the input; no sequence larger than the input could hold.
#include "fuzz_support.hpp"
#include "loopd/io/ros2_cdr.hpp"

namespace {
void check_result(bool ok, const std::string& error) {
  loopd::fuzz::check(ok == error.empty(), "ok exactly when there is no error");
  if (!ok) loopd::fuzz::check(error.rfind("CDR: ", 0) == 0, "an error names CDR and the field");
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  std::string error;
  Ros2PointCloud2 cloud;
  const bool cloud_ok = decode_cdr(data, size, &cloud, &error);
  check_result(cloud_ok, error);
  if (cloud_ok) {
    fuzz::check(cloud.data == nullptr ? cloud.size == 0 : (cloud.data >= data && cloud.data + cloud.size <= data + size), "data inside the input");
    fuzz::check(cloud.layout.fields.size() <= size / 13, "no more fields than the bytes hold");
    PointCloud2Options options;
    options.max_points = 100000;
    const PointCloud2Decoded points = decode_pointcloud2(cloud.layout, cloud.data, cloud.size, options);
    fuzz::check(points.ok == points.error.empty(), "the cloud decodes or says why");
  }
  error.clear();
  Ros2Odometry odometry;
  check_result(decode_cdr(data, size, &odometry, &error), error);
  error.clear();
  Ros2PoseStamped pose;
  check_result(decode_cdr(data, size, &pose, &error), error);
  error.clear();
  Ros2TfMessage tf;
  const bool tf_ok = decode_cdr(data, size, &tf, &error);
  check_result(tf_ok, error);
  if (tf_ok) fuzz::check(tf.transforms.size() <= size / 72, "no more transforms than the bytes hold");
  return 0;
}
