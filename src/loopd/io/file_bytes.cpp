#include "loopd/io/file_bytes.hpp"

#include <filesystem>
#include <fstream>

namespace loopd {

FileBytes read_file_bytes(const std::string& path, std::size_t max_bytes) {
  namespace fs = std::filesystem;
  FileBytes f;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) {
    f.error = path + ": cannot open (no such file)";
    return f;
  }
  if (fs::is_directory(st)) {
    f.error = path + ": is a directory, not a file";
    return f;
  }
  if (!fs::is_regular_file(st)) {
    f.error = path + ": not a regular file";
    return f;
  }
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) {
    f.error = path + ": cannot read its size (" + ec.message() + ")";
    return f;
  }
  if (size > max_bytes) {
    f.error = path + ": " + std::to_string(size) + " bytes is more than the " + std::to_string(max_bytes) + " bytes a cloud file may hold";
    return f;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    f.error = path + ": cannot open";
    return f;
  }
  f.bytes.assign(static_cast<std::size_t>(size), '\0');
  in.read(f.bytes.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) {
    f.error = path + ": read " + std::to_string(in.gcount()) + " of " + std::to_string(size) + " bytes (file changed while reading?)";
    return f;
  }
  f.ok = true;
  return f;
}

}  // namespace loopd
