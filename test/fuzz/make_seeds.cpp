// Writes the seed corpora of the fuzz targets (test/fuzz/corpus/<name>/) with loopd's own writers and lcm-gen's
// encoders: small valid inputs of each format. Usage: fuzz_make_seeds <corpus dir>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "loopd/runtime/daemon_config.hpp"
#include "lcm_log.hpp"
#include "loopd/base/trajectory_io.hpp"
#include "loopd/io/cloud_file.hpp"
#include "message_convert.hpp"

namespace fs = std::filesystem;
using namespace loopd;

namespace {

std::string root;

void put(const std::string& target, const std::string& name, const std::string& bytes) {
  fs::create_directories(root + "/" + target);
  std::ofstream(root + "/" + target + "/" + name, std::ios::binary) << bytes;
}

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

PointCloud small_cloud(int n) {
  PointCloud c;
  for (int i = 0; i < n; ++i) {
    c.points.emplace_back(0.5f * static_cast<float>(i), -1.25f + static_cast<float>(i), 0.125f * static_cast<float>(i % 3));
    c.intensity.push_back(static_cast<float>(10 * i));
  }
  return c;
}

template <typename T>
std::string raw(const T& v) {
  return std::string(reinterpret_cast<const char*>(&v), sizeof(T));
}

template <typename Msg>
std::string encode(const Msg& m) {
  std::string out(static_cast<std::size_t>(m.getEncodedSize()), '\0');
  m.encode(out.data(), 0, static_cast<int>(out.size()));
  return out;
}

/// LZF with literal runs only (a valid stream of the format; the fuzzer finds back references).
std::string lzf_literals(const std::string& in) {
  std::string out;
  for (std::size_t i = 0; i < in.size(); i += 32) {
    const std::size_t n = std::min<std::size_t>(32, in.size() - i);
    out += static_cast<char>(n - 1);
    out += in.substr(i, n);
  }
  return out;
}

void clouds() {
  const PointCloud c = small_cloud(6);
  const std::string bin = root + "/cloud_bin/six_points.bin";
  fs::create_directories(root + "/cloud_bin");
  write_kitti_bin(bin, c);
  put("cloud_bin", "empty.bin", "");

  const std::string head =
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\n"
      "COUNT 1 1 1 1\nWIDTH 6\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 6\n";
  std::string ascii = head + "DATA ascii\n", binary = head + "DATA binary\n", soa;
  for (std::size_t i = 0; i < c.size(); ++i) {
    ascii += std::to_string(c.points[i].x()) + " " + std::to_string(c.points[i].y()) + " " + std::to_string(c.points[i].z()) + " " +
             std::to_string(c.intensity[i]) + "\n";
    binary += raw(c.points[i].x()) + raw(c.points[i].y()) + raw(c.points[i].z()) + raw(c.intensity[i]);
  }
  for (int k = 0; k < 4; ++k)
    for (std::size_t i = 0; i < c.size(); ++i) soa += raw(k < 3 ? c.points[i][k] : c.intensity[i]);
  const std::string lzf = lzf_literals(soa);
  put("cloud_pcd", "ascii.pcd", ascii);
  put("cloud_pcd", "binary.pcd", binary);
  put("cloud_pcd", "binary_compressed.pcd",
      head + "DATA binary_compressed\n" + raw(static_cast<std::uint32_t>(lzf.size())) + raw(static_cast<std::uint32_t>(soa.size())) + lzf);
  // Mixed types and counts, and a field before x.
  std::string mixed =
      "VERSION .7\nFIELDS ring x y z normal\nSIZE 2 8 8 8 4\nTYPE U F F F F\nCOUNT 1 1 1 1 3\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary\n";
  for (int i = 0; i < 2; ++i) {
    mixed += raw(static_cast<std::uint16_t>(i)) + raw(1.0 * i) + raw(2.0) + raw(-3.0);
    for (int k = 0; k < 3; ++k) mixed += raw(0.5f);
  }
  put("cloud_pcd", "mixed_types.pcd", mixed);

  const std::string ply_props =
      "element vertex 6\nproperty float x\nproperty float y\nproperty float z\nproperty float intensity\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  std::string ply_ascii = "ply\nformat ascii 1.0\ncomment loopd seed\n" + ply_props, le = "ply\nformat binary_little_endian 1.0\n" + ply_props,
              be = "ply\nformat binary_big_endian 1.0\n" + ply_props;
  for (std::size_t i = 0; i < c.size(); ++i) {
    ply_ascii += std::to_string(c.points[i].x()) + " " + std::to_string(c.points[i].y()) + " " + std::to_string(c.points[i].z()) + " " +
                 std::to_string(c.intensity[i]) + "\n";
    for (float v : {c.points[i].x(), c.points[i].y(), c.points[i].z(), c.intensity[i]}) {
      std::string b = raw(v);
      le += b;
      be += std::string(b.rbegin(), b.rend());
    }
  }
  ply_ascii += "3 0 1 2\n";
  le += std::string(1, '\3') + raw(0) + raw(1) + raw(2);
  be += std::string(1, '\3') + std::string(4, '\0') + std::string("\0\0\0\1", 4) + std::string("\0\0\0\2", 4);
  put("cloud_ply", "ascii.ply", ply_ascii);
  put("cloud_ply", "binary_le.ply", le);
  put("cloud_ply", "binary_be.ply", be);
  put("cloud_ply", "list_before_vertex.ply",
      "ply\nformat binary_little_endian 1.0\nelement extra 2\nproperty list uchar double v\nelement vertex 1\nproperty double x\n"
      "property double y\nproperty double z\nend_header\n" +
          std::string(1, '\1') + raw(1.0) + std::string(1, '\0') + raw(1.0) + raw(2.0) + raw(3.0));
}

std::vector<Eigen::Isometry3d> small_trajectory(int n) {
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < n; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.3 * i, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(2.0 * std::cos(0.3 * i), 2.0 * std::sin(0.3 * i), 0.01 * i);
    poses.push_back(T);
  }
  return poses;
}

void text_files() {
  const auto poses = small_trajectory(6);
  std::vector<double> stamps;
  for (int i = 0; i < 6; ++i) stamps.push_back(0.1 * i);
  fs::create_directories(root + "/trajectory");
  fs::create_directories(root + "/kitti_text");
  write_trajectory(root + "/trajectory/kitti.txt", poses, stamps, TrajectoryFormat::kKitti);
  write_trajectory(root + "/trajectory/tum.txt", poses, stamps, TrajectoryFormat::kTum);
  write_trajectory(root + "/kitti_text/poses.txt", poses, stamps, TrajectoryFormat::kKitti);
  put("kitti_text", "times.txt", "0.000000e+00\n1.037359e-01\n2.073854e-01\n3.110450e-01\n");
  put("kitti_text", "calib.txt",
      "P0: 7.18e+02 0 6.07e+02 0 0 7.18e+02 1.85e+02 0 0 0 1 0\n"
      "Tr: 4.276802385584e-04 -9.999672484946e-01 -8.084491683471e-03 -1.198459927713e-02 -7.210626507497e-03 "
      "8.081198471645e-03 -9.999413164504e-01 -5.403984729748e-02 9.999738645903e-01 4.859485810390e-04 -7.206933692422e-03 "
      "-2.921968648686e-01\n");
  const std::string loops = "# query match T_match_query\n5 0 1 0 0 0.1 0 1 0 0 0 0 1 0\n4 1 1 0 0 0 0 1 0 0.2 0 0 1 0\n";
  const std::string residuals = "0\n0.01\n0.02\n0.01\n0.05\n0.01\n";
  put("loops", "loops.txt", loops);
  put("loops", "residuals.txt", residuals);
  const std::string kitti = file_text(root + "/trajectory/kitti.txt"), tum = file_text(root + "/trajectory/tum.txt");
  put("correct", "kitti_heuristic", std::string(1, '\0') + kitti + "===\n" + loops + "===\n" + residuals);
  put("correct", "tum_graph", std::string(1, '\3') + tum + "===\n" + loops + "===\n" + residuals);
  put("correct", "kitti_both_no_residuals", std::string(1, '\4') + kitti + "===\n" + loops);
}

void configs(const std::string& source_dir) {
  put("config", "example.yaml", file_text(source_dir + "/daemon/loopd.example.yaml"));
  put("config", "defaults.yaml", dump_config(DaemonConfig()));
  put("config", "small.yaml", "sensor: hdl64\nthreads: 2\ngate:\n  min_radius: 5.0\nchannels:\n  scan: LIDAR_SCAN\n");
}

void messages() {
  PointCloud c = small_cloud(5);
  put("decode_point_cloud", "five_points", encode(to_message(c, 1000, 7, "velodyne")));
  c.ring = {0, 1, 2, 3, 4};
  c.num_rings = 16;
  put("decode_point_cloud", "five_points_rings", encode(to_message(c, 2000, 8, "os1")));
  c.time = {-0.1f, -0.075f, -0.05f, -0.025f, 0.0f};
  put("decode_point_cloud", "five_points_rings_times", encode(to_message(c, 3000, 9, "os1")));
  // Version 1 (before per-point times): today's bytes without num_point_times, with that version's fingerprint.
  c.time.clear();
  std::string v1 = encode(to_message(c, 4000, 10, "velodyne"));
  v1.resize(v1.size() - 4);
  for (int i = 0; i < 8; ++i) v1[static_cast<std::size_t>(i)] = static_cast<char>(static_cast<std::uint64_t>(kPointCloudV1Hash) >> (56 - 8 * i));
  put("decode_point_cloud", "five_points_rings_v1", v1);
  StampedPose p;
  p.utime = 123456;
  p.T_world_sensor = small_trajectory(3).back();
  p.residual = 0.02;
  put("decode_pose", "pose", encode(to_message(p, 3)));
  loop_event_t ev{};
  ev.utime = 5;
  ev.event_id = 1;
  ev.query_id = 40;
  ev.match_id = 3;
  ev.status = loop_event_t::STATUS_ACCEPTED;
  ev.stage = "gicp";
  ev.reason = "accepted";
  for (int i = 0; i < 16; ++i) ev.T_match_query[i] = (i % 5 == 0) ? 1.0 : 0.0;
  ev.retrieval = "gate";
  ev.place_distance = -1.0;
  const std::string gated = encode(ev);
  std::string ev_v1 = gated.substr(0, gated.size() - 25);  // version 1: before sessions, retrieval, place_distance
  for (int i = 0; i < 8; ++i) ev_v1[static_cast<std::size_t>(i)] = static_cast<char>(0x0ca921302b50cd2aULL >> (56 - 8 * i));
  put("decode_loop_event", "accepted_v1", ev_v1);
  ev.query_session = 1;
  ev.retrieval = "global";
  ev.place_distance = 0.21;
  put("decode_loop_event", "accepted", encode(ev));
  trajectory_t tr{};
  tr.revision = 2;
  tr.method = "heuristic+graph";
  for (int i = 0; i < 16; ++i) tr.T_map_odom[i] = (i % 5 == 0) ? 1.0 : 0.0;
  for (int i = 0; i < 3; ++i) {
    keyframe_pose_t k{};
    k.id = i;
    k.utime = 100 * i;
    k.position[0] = i;
    k.orientation[0] = 1.0;
    tr.keyframes.push_back(k);
    tr.keyframe_sessions.push_back(i == 2 ? 1 : 0);
  }
  tr.num_keyframes = 3;
  session_alignment_t sa{};
  sa.session = 1;
  sa.anchored = true;
  for (int i = 0; i < 16; ++i) sa.T_map_session[i] = (i % 5 == 0) ? 1.0 : 0.0;
  sa.num_keyframes = 1;
  tr.sessions.push_back(sa);
  tr.num_sessions = 1;
  put("decode_trajectory", "three_keyframes", encode(tr));
  status_t st{};
  st.utime = 9;
  for (const char* ch : {"LIDAR_SCAN", "ODOMETRY_POSE"}) {
    channel_stats_t cs{};
    cs.channel = ch;
    cs.received = 10;
    cs.accepted = 9;
    cs.malformed = 1;
    st.channels.push_back(cs);
  }
  st.num_channels = 2;
  put("decode_status", "two_channels", encode(st));

  std::string err;
  LogWriter w;
  fs::create_directories(root + "/lcm_log");
  w.open(root + "/lcm_log/drive_log", &err);  // no .lcmlog: .gitignore drops those
  ImuSample g;
  g.utime = 999;
  g.angular_velocity = Eigen::Vector3d(0.01, -0.02, 0.5);
  w.write_message("IMU", 999, to_message(g, 0));
  w.write_message("ODOMETRY_POSE", 1000, to_message(p, 0));
  w.write_message("LIDAR_SCAN", 1001, to_message(small_cloud(3), 1000, 0, "velodyne"));
  w.write_message("LOOPD_STATUS", 1002, st);
  w.close();
}

/// fuzz_pointcloud2's input: the layout (see fuzz_pointcloud2.cpp), then the data bytes.
struct Cloud2Seed {
  std::string bytes;
  Cloud2Seed(std::uint32_t height, std::uint32_t width, std::uint32_t point_step, std::uint32_t row_step, bool big_endian) {
    bytes = raw(height) + raw(width) + raw(point_step) + raw(row_step) + std::string(1, big_endian ? '\1' : '\0');
  }
  /// name: index into fuzz_pointcloud2's names (0 x, 1 y, 2 z, 3 intensity, 4 ring, 5 laser_id, 6 time).
  void fields(const std::vector<std::array<std::uint32_t, 3>>& f) {  // {name, offset, datatype}, count 1
    bytes += static_cast<char>(f.size());
    for (const auto& x : f)
      bytes += std::string(1, static_cast<char>(x[0])) + raw(x[1]) + std::string(1, static_cast<char>(x[2])) + raw(std::uint32_t{1});
  }
};

template <typename T>
std::string raw_be(T v) {
  const std::string b = raw(v);
  return std::string(b.rbegin(), b.rend());
}

void pointcloud2() {
  const PointCloud c = small_cloud(6);
  // The velodyne driver's layout: float32 x y z, pad, float32 intensity, uint16 ring, pad, float32 time; 28 bytes.
  Cloud2Seed velodyne(1, 6, 28, 6 * 28, false);
  velodyne.fields({{0, 0, 7}, {1, 4, 7}, {2, 8, 7}, {3, 16, 7}, {4, 20, 4}, {6, 24, 7}});
  for (std::size_t i = 0; i < c.size(); ++i)
    velodyne.bytes += raw(c.points[i].x()) + raw(c.points[i].y()) + raw(c.points[i].z()) + raw(0.f) + raw(c.intensity[i]) +
                      raw(static_cast<std::uint16_t>(i)) + std::string(2, '\0') + raw(0.01f * static_cast<float>(i));
  put("pointcloud2", "velodyne", velodyne.bytes);
  // Big-endian float64 x y z and an int32 laser_id; 2 rows x 3 columns with a NaN cell and 4 bytes of row padding.
  Cloud2Seed be(2, 3, 28, 3 * 28 + 4, true);
  be.fields({{0, 0, 8}, {1, 8, 8}, {2, 16, 8}, {5, 24, 5}});
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double x = i == 4 ? std::nan("") : static_cast<double>(c.points[i].x());
    be.bytes += raw_be(x) + raw_be(static_cast<double>(c.points[i].y())) + raw_be(static_cast<double>(c.points[i].z())) +
                raw_be(static_cast<std::int32_t>(i));
    if (i % 3 == 2) be.bytes += std::string(4, '\0');
  }
  put("pointcloud2", "organised_big_endian", be.bytes);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: fuzz_make_seeds <corpus dir> <source dir>\n";
    return 2;
  }
  root = argv[1];
  clouds();
  pointcloud2();
  text_files();
  configs(argv[2]);
  messages();
  std::cout << "seeds written to " << root << "\n";
  return 0;
}
