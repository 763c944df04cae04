// ROS 2 messages from CDR (src/loopd/io/ros2_cdr): written by @foxglove/rosmsg2-serialization (npm) with ROS 2
// Humble's definitions, a big-endian message laid out by hand, and every truncation of each message refused.
#include <catch2/catch.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "loopd/io/ros2_cdr.hpp"
#include "support/npm_tools.hpp"

using namespace loopd;

namespace {

std::vector<std::uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Every proper prefix of `bytes` is refused with a field named (nothing read past the end: ASan builds check it).
template <typename Msg>
void every_truncation_refused(const std::vector<std::uint8_t>& bytes, std::size_t keep_at_least) {
  for (std::size_t n = 0; n + keep_at_least < bytes.size(); ++n) {
    Msg m;
    std::string error;
    const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n));
    INFO(n << " of " << bytes.size() << " bytes");
    CHECK_FALSE(decode_cdr(cut.data(), cut.size(), &m, &error));
    CHECK(error.find("CDR: ") == 0);
  }
}

}  // namespace

TEST_CASE("ROS 2 CDR: PointCloud2, Odometry, PoseStamped and TFMessage written by @foxglove/rosmsg2-serialization (npm)") {
  if (!loopd::test::npm_tools({"@foxglove/rosmsg2-serialization@3.1.0", "@foxglove/rosmsg-msgs-common@3.2.3"})) {
    WARN("skipped: node, npm or the npm registry (@foxglove/rosmsg2-serialization) is not available");
    return;
  }
  const std::string out = loopd::test::npm_tools_folder() + "/cdr";
  std::filesystem::create_directories(out);
  REQUIRE(loopd::test::run_node("io/npm/write_cdr.mjs", out) == 0);
  std::string error;

  const std::vector<std::uint8_t> cloud_bytes = read_bytes(out + "/pointcloud2.cdr");
  Ros2PointCloud2 cloud;
  REQUIRE(decode_cdr(cloud_bytes.data(), cloud_bytes.size(), &cloud, &error));
  CHECK(cloud.header.sec == 1700000000);
  CHECK(cloud.header.nanosec == 123456789u);
  CHECK(cloud.header.utime() == 1700000000123456);
  CHECK(cloud.header.frame_id == "os_sensor");
  CHECK(cloud.layout.width == 3);
  CHECK(cloud.layout.point_step == 22);
  REQUIRE(cloud.layout.fields.size() == 6);
  CHECK(cloud.layout.fields[4].name == "ring");
  CHECK(cloud.layout.fields[4].datatype == 4);
  CHECK(cloud.layout.fields[5].offset == 18);
  CHECK(cloud.size == 66);
  CHECK(cloud.is_dense);
  // The data through the PointCloud2 decoder bag2lcm uses for ROS 1: points, intensities, rings, Ouster-style times.
  PointCloud2Options options;
  options.stamp = 1700000000.123456789;
  const PointCloud2Decoded points = decode_pointcloud2(cloud.layout, cloud.data, cloud.size, options);
  REQUIRE(points.ok);
  REQUIRE(points.cloud.size() == 3);
  CHECK(points.cloud.points[2].x() == 7.0f);
  CHECK(points.cloud.intensity[1] == 20.0f);
  CHECK(points.cloud.ring[2] == 15);
  REQUIRE(points.time.size() == 3);
  CHECK(points.time[2] == Approx(99e-6));
  every_truncation_refused<Ros2PointCloud2>(cloud_bytes, 4);  // the last field, is_dense, may lose its padding only

  const std::vector<std::uint8_t> odometry_bytes = read_bytes(out + "/odometry.cdr");
  Ros2Odometry odometry;
  REQUIRE(decode_cdr(odometry_bytes.data(), odometry_bytes.size(), &odometry, &error));
  CHECK(odometry.header.frame_id == "odom");
  CHECK(odometry.header.nanosec == 5000u);
  CHECK(odometry.child_frame_id == "base_link");
  CHECK(odometry.pose.position[1] == -2.25);
  CHECK(odometry.pose.orientation[2] == 0.6);
  CHECK(odometry.pose.orientation[3] == 0.8);

  const std::vector<std::uint8_t> pose_bytes = read_bytes(out + "/pose_stamped.cdr");
  Ros2PoseStamped pose;
  REQUIRE(decode_cdr(pose_bytes.data(), pose_bytes.size(), &pose, &error));
  CHECK(pose.header.frame_id == "map");
  CHECK(pose.pose.position[0] == 1.5);
  every_truncation_refused<Ros2PoseStamped>(pose_bytes, 0);

  const std::vector<std::uint8_t> tf_bytes = read_bytes(out + "/tf_message.cdr");
  Ros2TfMessage tf;
  REQUIRE(decode_cdr(tf_bytes.data(), tf_bytes.size(), &tf, &error));
  REQUIRE(tf.transforms.size() == 2);
  CHECK(tf.transforms[0].header.frame_id == "odom");
  CHECK(tf.transforms[0].child_frame_id == "base_link");
  CHECK(tf.transforms[0].translation[2] == 3.0);
  CHECK(tf.transforms[1].child_frame_id == "os_sensor");
  CHECK(tf.transforms[1].rotation[3] == 0.8);
  every_truncation_refused<Ros2TfMessage>(tf_bytes, 0);
}

TEST_CASE("ROS 2 CDR: a big-endian PoseStamped laid out by hand, and counts no message could hold refused before allocating") {
  // Encapsulation 00 00 (CDR, big endian); stamp 2 s 3 ns; frame_id "m" (length 2 with its NUL); 3 bytes of padding
  // to the doubles' 8-byte alignment from the payload's start (offset 16); position 1, 2, 3; orientation 0, 0, 0, 1.
  std::vector<std::uint8_t> b = {0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 2, 'm', 0, 0, 0};
  const auto push_double = [&](double v) {
    std::uint64_t u;
    std::memcpy(&u, &v, 8);
    for (int i = 7; i >= 0; --i) b.push_back(static_cast<std::uint8_t>(u >> (8 * i)));
  };
  for (double v : {1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0}) push_double(v);
  Ros2PoseStamped pose;
  std::string error;
  REQUIRE(decode_cdr(b.data(), b.size(), &pose, &error));
  CHECK(pose.header.sec == 2);
  CHECK(pose.header.nanosec == 3u);
  CHECK(pose.header.frame_id == "m");
  CHECK(pose.pose.position[2] == 3.0);
  CHECK(pose.pose.orientation[3] == 1.0);

  // A TFMessage claiming 2^32 - 1 transforms in 8 bytes, and a PointCloud2 whose data claims 4 GB: refused by count.
  const std::vector<std::uint8_t> tf = {0, 1, 0, 0, 0xff, 0xff, 0xff, 0xff};
  Ros2TfMessage m;
  CHECK_FALSE(decode_cdr(tf.data(), tf.size(), &m, &error));
  CHECK(error.find("transforms") != std::string::npos);
  const std::vector<std::uint8_t> bad_header = {1, 2, 0, 0};
  CHECK_FALSE(decode_cdr(bad_header.data(), bad_header.size(), &m, &error));
  CHECK(error.find("encapsulation") != std::string::npos);
}
