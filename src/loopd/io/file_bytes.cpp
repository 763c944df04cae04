#include "loopd/io/file_bytes.hpp"

#include <filesystem>
#include <fstream>

namespace loopd {

bool read_file_bytes(const std::string& path, std::string* bytes, std::string* error, std::size_t max_bytes) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) {
    *error = path + ": cannot open (no such file)";
    return false;
  }
  if (fs::is_directory(st)) {
    *error = path + ": is a directory, not a file";
    return false;
  }
  if (!fs::is_regular_file(st)) {
    *error = path + ": not a regular file";
    return false;
  }
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) {
    *error = path + ": cannot read its size (" + ec.message() + ")";
    return false;
  }
  if (size > max_bytes) {
    *error = path + ": " + std::to_string(size) + " bytes is more than the " + std::to_string(max_bytes) + " bytes a cloud file may hold";
    return false;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = path + ": cannot open";
    return false;
  }
  bytes->assign(static_cast<std::size_t>(size), '\0');
  in.read(bytes->data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) {
    *error = path + ": read " + std::to_string(in.gcount()) + " of " + std::to_string(size) + " bytes (file changed while reading?)";
    return false;
  }
  return true;
}

}  // namespace loopd
