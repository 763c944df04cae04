#pragma once
#include <cstddef>
#include <string>

namespace loopd {

/// @brief Reads a whole regular file into `bytes`. Refuses directories, devices, FIFOs and files larger than
///        `max_bytes`, with an error that names the file ("<path>: is a directory", "<path>: cannot open").
bool read_file_bytes(const std::string& path, std::string* bytes, std::string* error,
                     std::size_t max_bytes = std::size_t{4} << 30);

}  // namespace loopd
