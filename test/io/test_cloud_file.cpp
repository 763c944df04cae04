// Point cloud files (.bin, .pcd, .ply) through read_cloud_file: good files of every encoding read back exactly, and
// damaged or hostile ones fail with an error that names the file and the position, without allocating what a
// header merely declares.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "loopd/io/cloud_file.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {

struct TempDir {
  fs::path dir = fs::temp_directory_path() / ("loopd_test_io_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(dir); }
  ~TempDir() { fs::remove_all(dir); }
  std::string write(const std::string& name, const std::string& bytes) const {
    const std::string p = (dir / name).string();
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }
};

template <typename T>
std::string raw(T v) {
  return std::string(reinterpret_cast<const char*>(&v), sizeof(T));
}
std::string reversed(const std::string& s) { return std::string(s.rbegin(), s.rend()); }

/// Three points with distinct values: (1.5, -2, 0.25, i=7), (3, 4, -5.5, i=8), (-0.125, 100, 9, i=9).
const float kPts[3][4] = {{1.5f, -2.f, 0.25f, 7.f}, {3.f, 4.f, -5.5f, 8.f}, {-0.125f, 100.f, 9.f, 9.f}};

void require_three_points(const PointCloud& c, bool intensity = true) {
  REQUIRE(c.size() == 3);
  REQUIRE(c.has_intensity() == intensity);
  for (int i = 0; i < 3; ++i) {
    CHECK(c.points[static_cast<std::size_t>(i)].x() == kPts[i][0]);
    CHECK(c.points[static_cast<std::size_t>(i)].y() == kPts[i][1]);
    CHECK(c.points[static_cast<std::size_t>(i)].z() == kPts[i][2]);
    if (intensity) CHECK(c.intensity[static_cast<std::size_t>(i)] == kPts[i][3]);
  }
}

/// Reads `path`, expecting failure; returns the error.
std::string read_error(const std::string& path) {
  const CloudFile f = read_cloud_file(path);
  CHECK_FALSE(f.ok);
  CHECK(f.cloud.empty());
  INFO(f.error);
  CHECK(f.error.find(path) != std::string::npos);
  return f.error;
}

/// Reads `path`, expecting success; returns the cloud.
PointCloud read_ok(const std::string& path) {
  const CloudFile f = read_cloud_file(path);
  INFO(f.error);
  REQUIRE(f.ok);
  CHECK(f.error.empty());
  return f.cloud;
}

const std::string kPcdHead =
    "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 3\nHEIGHT 1\n"
    "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\n";

}  // namespace

TEST_CASE("cloud files: .bin, .pcd (ascii, binary, binary_compressed, mixed types) and .ply (ascii, both byte orders) read exactly", "[io]") {
  TempDir tmp;
  PointCloud c;

  std::string bin;
  for (const auto& p : kPts)
    for (float v : p) bin += raw(v);
  c = read_ok(tmp.write("a.bin", bin));
  require_three_points(c);

  std::string ascii = kPcdHead + "DATA ascii\n", binary = kPcdHead + "DATA binary\n", soa;
  for (const auto& p : kPts) {
    ascii += std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + " " + std::to_string(p[3]) + "\n";
    for (float v : p) binary += raw(v);
  }
  for (int k = 0; k < 4; ++k)
    for (const auto& p : kPts) soa += raw(p[k]);
  c = read_ok(tmp.write("ascii.pcd", ascii));
  require_three_points(c);
  c = read_ok(tmp.write("binary.PCD", binary));
  require_three_points(c);
  // LZF: a literal run of all 48 bytes needs two runs (at most 32 bytes each); then a back reference test below.
  const std::string lzf = std::string(1, '\x1f') + soa.substr(0, 32) + std::string(1, '\x0f') + soa.substr(32);
  c = read_ok(tmp.write("c.pcd", kPcdHead + "DATA binary_compressed\n" + raw(std::uint32_t(lzf.size())) + raw(std::uint32_t(48)) + lzf));
  require_three_points(c);
  // A back reference: 8 literal bytes then "copy 8 bytes from 8 back" gives the same 8 bytes twice.
  const std::string xyz_head = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4\nHEIGHT 1\nPOINTS 4\nDATA binary_compressed\n";
  // 48 bytes: x of 4 points = 1,1,1,1 (16 bytes), y = 1,1,1,1, z = 1,1,1,1: 4 literal bytes then a 44-byte reference
  // at distance 4 (ctrl: len 7 -> 7 + extra; 44 - 2 = 42 = 7 + 35).
  const std::string one = raw(1.0f);
  const std::string backref =
      std::string(1, '\x03') + one + std::string(1, static_cast<char>(7 << 5)) + std::string(1, '\x23') + std::string(1, '\x03');
  c = read_ok(tmp.write("ref.pcd", xyz_head + raw(std::uint32_t(backref.size())) + raw(std::uint32_t(48)) + backref));
  REQUIRE(c.size() == 4);
  CHECK_FALSE(c.has_intensity());
  for (const auto& p : c.points) CHECK(p == Eigen::Vector3f(1.f, 1.f, 1.f));

  // Mixed types: a uint16 field before x, doubles, a 3-count field after.
  std::string mixed =
      "VERSION .7\nFIELDS ring x y z normal\nSIZE 2 8 8 8 4\nTYPE U F F F F\nCOUNT 1 1 1 1 3\nWIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA binary\n";
  for (const auto& p : kPts) {
    mixed += raw(std::uint16_t(5)) + raw(double(p[0])) + raw(double(p[1])) + raw(double(p[2]));
    for (int k = 0; k < 3; ++k) mixed += raw(0.5f);
  }
  c = read_ok(tmp.write("mixed.pcd", mixed));
  require_three_points(c, false);

  const std::string props =
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float intensity\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  std::string ply_ascii = "ply\nformat ascii 1.0\ncomment made by a test\n" + props;
  std::string le = "ply\nformat binary_little_endian 1.0\n" + props, be = "ply\nformat binary_big_endian 1.0\n" + props;
  for (const auto& p : kPts) {
    ply_ascii += std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + " " + std::to_string(p[3]) + "\n";
    for (float v : p) {
      le += raw(v);
      be += reversed(raw(v));
    }
  }
  c = read_ok(tmp.write("a.ply", ply_ascii + "3 0 1 2\n"));
  require_three_points(c);
  c = read_ok(tmp.write("le.ply", le + "\x03" + raw(0) + raw(1) + raw(2)));
  require_three_points(c);
  c = read_ok(tmp.write("be.ply", be + "\x03" + reversed(raw(0)) + reversed(raw(1)) + reversed(raw(2))));
  require_three_points(c);
  // An element with a list before the vertices is walked over.
  std::string before =
      "ply\nformat binary_little_endian 1.0\nelement extra 2\nproperty list uchar double v\nelement vertex 3\n"
      "property float x\nproperty float y\nproperty float z\nproperty float intensity\nend_header\n";
  before += std::string(1, '\x02') + raw(1.0) + raw(2.0) + std::string(1, '\x00');
  for (const auto& p : kPts)
    for (float v : p) before += raw(v);
  c = read_ok(tmp.write("before.ply", before));
  require_three_points(c);

  // NaN and Inf are kept (callers filter them); a number beyond float's range becomes inf.
  c = read_ok(tmp.write("nan.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nPOINTS 2\nDATA ascii\nnan 1 2\n1e99 -inf 0\n"));
  REQUIRE(c.size() == 2);
  CHECK(std::isnan(c.points[0].x()));
  CHECK(c.points[1].x() == HUGE_VALF);
  CHECK(c.points[1].y() == -HUGE_VALF);
  // An empty .bin is a cloud of no points.
  c = read_ok(tmp.write("empty.bin", ""));
  CHECK(c.empty());
}

TEST_CASE("cloud files: damaged and hostile files fail with the file and the position, and allocate nothing they declare", "[io]") {
  TempDir tmp;
  std::string e;

  e = read_error(tmp.write("odd.bin", std::string(37, '\0')));
  CHECK(e.find("byte offset 32") != std::string::npos);
  CHECK(e.find("not a multiple of 16") != std::string::npos);
  fs::create_directories(tmp.dir / "dir.bin");
  CHECK(read_error((tmp.dir / "dir.bin").string()).find("is a directory") != std::string::npos);
  CHECK(read_error((tmp.dir / "missing.pcd").string()).find("no such file") != std::string::npos);
  CHECK(read_error(tmp.write("cloud.xyz", "1 2 3\n")).find("unknown point cloud format") != std::string::npos);

  // A PCD header that declares 2^31 points over a 3-byte body: refused before anything is sized.
  const std::string huge = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2147483648\nHEIGHT 1\nPOINTS 2147483648\nDATA binary\n";
  e = read_error(tmp.write("huge.pcd", huge + "abc"));
  CHECK(e.find("byte offset " + std::to_string(huge.size())) != std::string::npos);
  CHECK(e.find("2147483648 points") != std::string::npos);
  // The same for ascii (points are counted as lines are read) and compressed (sizes checked against the bytes).
  e = read_error(tmp.write("huge_ascii.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2147483648\nPOINTS 2147483648\nDATA ascii\n1 2 3\n"));
  CHECK(e.find(":7: the file ends after 1 of the 2147483648 points") != std::string::npos);
  const std::string chead = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000000\nPOINTS 1000000\nDATA binary_compressed\n";
  e = read_error(tmp.write("bomb.pcd", chead + raw(std::uint32_t(4)) + raw(std::uint32_t(12000000)) + std::string("\x00\x01\x02\x03", 4)));
  CHECK(e.find("byte offset " + std::to_string(chead.size() + 4) + ": uncompressed size 12000000 cannot come from 4 LZF bytes") != std::string::npos);
  e = read_error(tmp.write("lie.pcd", chead + raw(std::uint32_t(4)) + raw(std::uint32_t(12)) + std::string("\x00\x01\x02\x03", 4)));
  CHECK(e.find("uncompressed size 12 is not POINTS * point size") != std::string::npos);
  const std::string small = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA binary_compressed\n";
  e = read_error(tmp.write("backref.pcd", small + raw(std::uint32_t(3)) + raw(std::uint32_t(12)) + std::string("\x20\x05\x00", 3)));
  CHECK(e.find("byte offset " + std::to_string(small.size() + 8) + ": LZF: back reference before the start") != std::string::npos);

  // Header and ascii errors name the line.
  CHECK(read_error(tmp.write("nodata.pcd", "VERSION 0.7\nFIELDS x y z\n")).find(":2: no DATA line") != std::string::npos);
  CHECK(read_error(tmp.write("type.pcd", "FIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nPOINTS 1\nDATA ascii\n1 2 3\n")).find(":5: field 'z': SIZE 3") !=
        std::string::npos);
  CHECK(read_error(tmp.write("few.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 2\nDATA ascii\n1 2 3\n4 5\n"))
            .find(":7: expected 3 values, got 2") != std::string::npos);
  CHECK(read_error(tmp.write("word.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 1\nDATA ascii\n1 zz 3\n"))
            .find(":6: field 'y': 'zz' is not a number") != std::string::npos);
  CHECK(read_error(tmp.write("noz.pcd", "FIELDS x y\nSIZE 4 4\nTYPE F F\nPOINTS 0\nDATA ascii\n")).find("no 'z' field") != std::string::npos);
  CHECK(read_error(tmp.write("junk.pcd", std::string("\x7f"
                                                     "ELF\x02\x01\x01\0\0\0",
                                                     10)))
            .find(":1: binary bytes in the header") != std::string::npos);

  // PLY: a vertex count the bytes cannot hold, a bad token, a truncated header, a list length past the end.
  const std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  e = read_error(tmp.write("huge.ply", ply + std::string(24, '\0')));
  CHECK(e.find("byte offset " + std::to_string(ply.size()) + ": element 'vertex' declares 1000000000 vertices of 12 bytes") != std::string::npos);
  e = read_error(tmp.write(
      "bad.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 five 6\n"));
  CHECK(e.find(":9: property 'y': 'five' is not a number") != std::string::npos);
  CHECK(read_error(tmp.write("cut.ply", "ply\nformat ascii 1.0\nelement vertex 2\n")).find("no end_header") != std::string::npos);
  CHECK(read_error(tmp.write("notply.ply", "plyx\n")).find(":1: the file does not start with 'ply'") != std::string::npos);
  const std::string list =
      "ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list int int idx\nelement vertex 0\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n";
  e = read_error(tmp.write("list.ply", list + raw(std::int32_t(2000000000)) + raw(1)));
  CHECK(e.find("byte offset " + std::to_string(list.size() + 4) + ": the file ends in element 'face' 0 of 1 (property 'idx')") != std::string::npos);
  e = read_error(tmp.write("neg.ply", list + raw(std::int32_t(-1))));
  CHECK(e.find("byte offset " + std::to_string(list.size()) + ": list length of property 'idx' is negative") != std::string::npos);
}
