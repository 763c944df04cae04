// CloudWriter / write_cloud_file: .pcd and .ply files that loopd's bounds-checked readers read back exactly (points,
// intensity, the patched count), empty clouds, and errors that name the path (bad extension, unwritable path, a
// full disk).
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <random>

#include "loopd/io/cloud_file.hpp"
#include "loopd/io/cloud_writer.hpp"
#include "loopd/io/file_bytes.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {

struct TempDir {
  fs::path dir = fs::temp_directory_path() / ("loopd_test_cloud_writer_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(dir); }
  ~TempDir() { fs::remove_all(dir); }
  std::string path(const std::string& name) const { return (dir / name).string(); }
};

/// n points of a fixed seed, with intensity, spread over +-100 m (some with tiny and negative values).
PointCloud random_cloud(std::size_t n) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> xyz(-100.f, 100.f), in(0.f, 255.f);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    c.points.emplace_back(xyz(rng), xyz(rng), xyz(rng) * 1e-3f);
    c.intensity.push_back(in(rng));
  }
  return c;
}

void require_equal(const PointCloud& a, const PointCloud& b) {
  REQUIRE(a.size() == b.size());
  REQUIRE(b.has_intensity());
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const float ia = a.has_intensity() ? a.intensity[i] : 0.f;
    if (a.points[i] != b.points[i] || ia != b.intensity[i]) ++mismatches;
  }
  CHECK(mismatches == 0);
}

PointCloud read_ok(const std::string& path) {
  const CloudFile f = read_cloud_file(path);
  INFO(f.error);
  REQUIRE(f.ok);
  return f.cloud;
}

}  // namespace

TEST_CASE("write_cloud_file: a few thousand points with intensity read back exactly as .pcd and .ply", "[io]") {
  TempDir tmp;
  // 20000 points: more than one 16384-point chunk.
  const PointCloud cloud = random_cloud(20000);
  for (const std::string name : {"map.pcd", "map.ply", "MAP.PCD", "Map.Ply"}) {
    INFO(name);
    const std::string path = tmp.path(name);
    const auto error = write_cloud_file(path, cloud);
    INFO(error.value_or(""));
    REQUIRE_FALSE(error);
    require_equal(cloud, read_ok(path));
  }
  const FileBytes pcd = read_file_bytes(tmp.path("map.pcd"));
  REQUIRE(pcd.ok);
  CHECK(pcd.bytes.find("WIDTH 0000000020000\nHEIGHT 1\n") != std::string::npos);
  CHECK(pcd.bytes.find("POINTS 0000000020000\nDATA binary\n") != std::string::npos);
  const FileBytes ply = read_file_bytes(tmp.path("map.ply"));
  REQUIRE(ply.ok);
  CHECK(ply.bytes.rfind("ply\nformat binary_little_endian 1.0\n", 0) == 0);
  CHECK(ply.bytes.find("element vertex 0000000020000\n") != std::string::npos);
}

TEST_CASE("write_cloud_file: a cloud without intensity is written with intensity 0, an empty cloud reads back empty", "[io]") {
  TempDir tmp;
  PointCloud xyz = random_cloud(100);
  xyz.intensity.clear();
  for (const std::string ext : {".pcd", ".ply"}) {
    INFO(ext);
    REQUIRE_FALSE(write_cloud_file(tmp.path("xyz" + ext), xyz));
    require_equal(xyz, read_ok(tmp.path("xyz" + ext)));
    REQUIRE_FALSE(write_cloud_file(tmp.path("empty" + ext), PointCloud{}));
    CHECK(read_ok(tmp.path("empty" + ext)).empty());
  }
}

TEST_CASE("CloudWriter: streams points, counts them and patches the count at close", "[io]") {
  TempDir tmp;
  const PointCloud cloud = random_cloud(3000);
  for (const std::string ext : {".pcd", ".ply"}) {
    INFO(ext);
    const std::string path = tmp.path("stream" + ext);
    CloudWriter w;
    REQUIRE_FALSE(w.open(path));
    CHECK(w.is_open());
    for (std::size_t i = 0; i < cloud.size(); ++i) w.add(cloud.points[i], cloud.intensity[i]);
    CHECK(w.points_written() == 3000);
    REQUIRE_FALSE(w.close());
    CHECK_FALSE(w.is_open());
    w.add(Eigen::Vector3f(1.f, 2.f, 3.f), 4.f);  // after close: ignored
    CHECK(w.points_written() == 3000);
    require_equal(cloud, read_ok(path));
    // Reopening truncates: one point.
    REQUIRE_FALSE(w.open(path));
    w.add(Eigen::Vector3f(1.f, 2.f, 3.f), 4.f);
    REQUIRE_FALSE(w.close());
    const PointCloud one = read_ok(path);
    REQUIRE(one.size() == 1);
    CHECK(one.points[0] == Eigen::Vector3f(1.f, 2.f, 3.f));
    CHECK(one.intensity[0] == 4.f);
  }
}

TEST_CASE("CloudWriter: a bad extension, an unwritable path and a full disk are errors that name the path", "[io]") {
  TempDir tmp;
  CloudWriter w;
  for (const std::string name : {"map.bin", "map.txt", "map", "dir.pcd/map"}) {
    INFO(name);
    const std::string path = tmp.path(name);
    const auto error = w.open(path);
    REQUIRE(error);
    CHECK(error->find(path) != std::string::npos);
    CHECK(error->find("unknown point cloud format") != std::string::npos);
    CHECK_FALSE(fs::exists(path));
    CHECK(w.close());  // not open
    CHECK(write_cloud_file(path, random_cloud(3)));
  }
  const std::string missing_dir = tmp.path("no/such/dir/map.pcd");
  const auto error = write_cloud_file(missing_dir, random_cloud(3));
  REQUIRE(error);
  CHECK(error->find("cannot write " + missing_dir) != std::string::npos);

  // /dev/full takes the open and the header (buffered) but fails every flush: the failure surfaces at close().
  if (fs::exists("/dev/full")) {
    const std::string full = tmp.path("full.ply");
    fs::create_symlink("/dev/full", full);
    REQUIRE_FALSE(w.open(full));
    for (int i = 0; i < 40000; ++i) w.add(Eigen::Vector3f::Constant(static_cast<float>(i)), 1.f);
    const auto e = w.close();
    REQUIRE(e);
    CHECK(e->find(full) != std::string::npos);
    CHECK(e->find("write failed") != std::string::npos);
    CHECK(write_cloud_file(full, PointCloud{}));  // even the header alone fails at close
  }
}
