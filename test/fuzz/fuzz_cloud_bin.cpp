// KITTI .bin point clouds: any byte string parses or fails with an error naming the file and byte offset.
#include "fuzz_support.hpp"
#include "loopd/io/cloud_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  const std::string bytes = fuzz::as_string(data, size);
  const CloudFile file = parse_cloud_bytes(bytes, "fuzz.bin");
  const PointCloud& cloud = file.cloud;
  const std::string& error = file.error;
  fuzz::check(file.ok == error.empty(), "ok exactly when there is no error");
  if (!file.ok) fuzz::check(cloud.empty(), "a failed read hands out no points");
  if (file.ok) {
    fuzz::check(cloud.size() == size / 16 && cloud.has_intensity(), "one point per 16 bytes, with intensity");
  } else {
    fuzz::check_error_names(error, "fuzz.bin");
    fuzz::check(error.find("byte offset") != std::string::npos, "the error gives the byte offset");
  }
  return 0;
}
