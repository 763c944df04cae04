// loopd-register QUERY MATCH [--json] on simulated scans written as KITTI .bin files.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <unistd.h>

#include "loopd/base/lidar_model.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"

using namespace loopd;

namespace {
std::string tool_path() { return std::string(LOOPD_BINARY_DIR) + "/tools/loopd-register/loopd-register"; }

int run(const std::string& cmd, std::string* out) {
  out->clear();
  FILE* p = popen((cmd + " 2>/dev/null").c_str(), "r");
  if (p == nullptr) return -1;
  char buf[4096];
  std::size_t n = 0;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out->append(buf, n);
  const int status = pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

nlohmann::json last_json_line(const std::string& out) {
  const std::size_t end = out.find_last_not_of('\n');
  const std::size_t start = out.rfind('\n', end);
  return nlohmann::json::parse(out.substr(start == std::string::npos ? 0 : start + 1));
}

struct Files {
  std::filesystem::path dir, query, match;
  Eigen::Isometry3d T_match_query;
  Files() {
    dir = std::filesystem::temp_directory_path() / ("loopd_register_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const Town town = make_town(1);
    const LidarModel model = lidar_model_hdl64();
    const Eigen::Isometry3d A = street_pose(town, 1, 1, 1, 25.0);
    const double yaw = std::atan2(A.linear()(1, 0), A.linear()(0, 0)) + M_PI / 2;
    const Eigen::Isometry3d B = ground_pose(town, A.translation().x() + 1.41, A.translation().y() + 1.41, yaw);
    T_match_query = A.inverse() * B;
    query = dir / "query.bin";
    match = dir / "match.bin";
    REQUIRE_FALSE(write_kitti_bin(query.string(), simulate_scan(town, model, B, 11, 1, 1)));
    REQUIRE_FALSE(write_kitti_bin(match.string(), simulate_scan(town, model, A, 7, 1, 0)));
  }
  ~Files() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
};
}  // namespace

TEST_CASE("loopd-register --json prints T_match_query, lcp and ms, the transform is the true one") {
  const Files f;
  for (const std::string extra : {"", " --lidar hdl64"}) {
    std::string out;
    REQUIRE(run(tool_path() + " " + f.query.string() + " " + f.match.string() + " --json" + extra, &out) == 0);
    const nlohmann::json j = last_json_line(out);
    REQUIRE(j.contains("T_match_query"));
    REQUIRE(j["T_match_query"].size() == 16);
    double m[16];
    for (int i = 0; i < 16; ++i) m[i] = j["T_match_query"][static_cast<std::size_t>(i)].get<double>();
    const Eigen::Isometry3d T = from_row_major(m);
    const Eigen::Isometry3d e = f.T_match_query.inverse() * T;
    INFO("options '" << extra << "' lcp " << j["lcp"] << " rot err " << rotation_angle(e) * 180 / M_PI << " trans err " << e.translation().norm());
    CHECK(rotation_angle(e) * 180 / M_PI < 5.0);
    CHECK(e.translation().norm() < 0.5);
    CHECK(j["lcp"].get<double>() > 0.6);
    CHECK(j["ms"].get<double>() > 0.0);
  }
}

TEST_CASE("loopd-register prints a table and the matrix by default, and fails cleanly on bad input") {
  const Files f;
  std::string out;
  REQUIRE(run(tool_path() + " " + f.query.string() + " " + f.match.string(), &out) == 0);
  CHECK(out.find("T_match_query") != std::string::npos);
  CHECK(out.find("lcp") != std::string::npos);
  CHECK(run(tool_path() + " " + (f.dir / "missing.bin").string() + " " + f.match.string(), &out) != 0);
  CHECK(run(tool_path() + " " + f.query.string() + " " + f.match.string() + " --lidar nosuch", &out) != 0);
}
