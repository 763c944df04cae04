// KITTI .bin point clouds: any byte string parses or fails with an error naming the file and byte offset.
#include "fuzz_support.hpp"
#include "loopd/io/cloud_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  PointCloud cloud;
  std::string error;
  const std::string bytes = fuzz::as_string(data, size);
  if (parse_cloud_bytes(bytes, "fuzz.bin", &cloud, &error)) {
    fuzz::check(cloud.size() == size / 16 && cloud.has_intensity(), "one point per 16 bytes, with intensity");
  } else {
    fuzz::check_error_names(error, "fuzz.bin");
    fuzz::check(error.find("byte offset") != std::string::npos, "the error gives the byte offset");
  }
  return 0;
}
