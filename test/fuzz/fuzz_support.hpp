#pragma once
// Shared by the fuzz targets: a check that aborts (so libFuzzer keeps the input), the input as a string, and a temp
// file for readers that take a path.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

namespace loopd::fuzz {

/// @brief Aborts with a message when `ok` is false: libFuzzer then saves the input as a crash.
inline void check(bool ok, const char* what) {
  if (!ok) {
    std::fprintf(stderr, "fuzz check failed: %s\n", what);
    std::abort();
  }
}

inline std::string as_string(const std::uint8_t* data, std::size_t size) { return std::string(reinterpret_cast<const char*>(data), size); }

/// @brief A per-process temp file path with the given suffix; write() replaces its content.
class TempFile {
 public:
  explicit TempFile(const std::string& suffix) {
    const char* dir = std::getenv("TMPDIR");
    path_ = std::string(dir && *dir ? dir : "/tmp") + "/loopd_fuzz_" + std::to_string(::getpid()) + suffix;
  }
  ~TempFile() { std::remove(path_.c_str()); }
  const std::string& write(const std::uint8_t* data, std::size_t size) {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    return path_;
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// @brief An error must name its source (a file path or "<input>") so the user can find it.
inline void check_error_names(const std::string& error, const std::string& source) {
  check(!error.empty(), "a failed read gives an error message");
  check(error.find(source) != std::string::npos, "the error names the file");
}

}  // namespace loopd::fuzz
