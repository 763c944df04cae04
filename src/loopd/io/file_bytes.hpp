#pragma once
#include <cstddef>
#include <string>

namespace loopd {

/// @brief The bytes of a file, or ok == false with the reason.
struct FileBytes {
  std::string bytes;
  bool ok = false;
  std::string error;  ///< names the file: "<path>: is a directory, not a file", "<path>: cannot open (no such file)", ...
};

/// @brief Reads a whole regular file. Refuses directories, devices, FIFOs and files larger than `max_bytes`.
FileBytes read_file_bytes(const std::string& path, std::size_t max_bytes = std::size_t{4} << 30);

}  // namespace loopd
