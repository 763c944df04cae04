// page_out_library_code on a real read-only file mapping: the resident pages of the named file go, others stay.
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "loopd/runtime/heap_release.hpp"

namespace {

/// Resident bytes of the mapping that starts at `address`, from /proc/self/smaps (-1 when not found).
long long resident_bytes_at(const void* address) {
  std::ifstream smaps("/proc/self/smaps");
  std::string line;
  bool in_mapping = false;
  const auto wanted = reinterpret_cast<std::uintptr_t>(address);
  while (std::getline(smaps, line)) {
    const std::size_t dash = line.find('-');
    if (dash != std::string::npos && dash < 17 && line.find(' ') > dash && line.find(':') > line.find(' ')) {
      in_mapping = std::stoull(line.substr(0, dash), nullptr, 16) == wanted;
      continue;
    }
    if (in_mapping && line.rfind("Rss:", 0) == 0) return std::stoll(line.substr(4)) * 1024;
  }
  return -1;
}

struct MappedFile {
  std::string path;
  std::size_t bytes = 0;
  void* data = nullptr;
  MappedFile(const std::string& name, std::size_t size, int prot) : path("/tmp/" + name + std::to_string(getpid())), bytes(size) {
    std::ofstream(path, std::ios::binary) << std::string(size, 'x');
    const int fd = open(path.c_str(), prot & PROT_WRITE ? O_RDWR : O_RDONLY);
    data = mmap(nullptr, size, prot, MAP_PRIVATE, fd, 0);
    close(fd);
  }
  ~MappedFile() {
    munmap(data, bytes);
    std::remove(path.c_str());
  }
  long touch() const {
    long sum = 0;
    for (std::size_t i = 0; i < bytes; i += 4096) sum += static_cast<const char*>(data)[i];
    return sum;
  }
};

}  // namespace

TEST_CASE("page_out_library_code drops the resident pages of the named read-only mappings only") {
  const std::size_t bytes = 8u << 20;
  MappedFile code("loopd-test-libcompiler-", bytes, PROT_READ);
  MappedFile other("loopd-test-libother-", bytes, PROT_READ);
  MappedFile data("loopd-test-libcompiler-data-", bytes, PROT_READ | PROT_WRITE);
  REQUIRE(code.data != MAP_FAILED);
  REQUIRE(other.data != MAP_FAILED);
  REQUIRE(data.data != MAP_FAILED);
  CHECK(code.touch() + other.touch() + data.touch() == 3 * static_cast<long>(bytes / 4096) * 'x');
  REQUIRE(resident_bytes_at(code.data) == static_cast<long long>(bytes));
  REQUIRE(resident_bytes_at(data.data) == static_cast<long long>(bytes));

  const std::size_t advised = loopd::page_out_library_code({"loopd-test-libcompiler-"});
  CHECK(advised == bytes);                                                // the read-only mapping of that name only
  CHECK(resident_bytes_at(code.data) == 0);                               // gone from this process's resident set
  CHECK(resident_bytes_at(other.data) == static_cast<long long>(bytes));  // another file: untouched
  CHECK(resident_bytes_at(data.data) == static_cast<long long>(bytes));   // writable (may hold changes): untouched
  CHECK(code.touch() == static_cast<long>(bytes / 4096) * 'x');           // and the contents read back intact
  CHECK(loopd::page_out_library_code({"no-such-library"}) == 0);
}
