// --sensor auto: the ring structure read from scans of every preset, with and without ring indices; a non-repetitive
// pattern; a preset that does not fit; the real recordings where they are present.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "loopd/base/lidar_model.hpp"
#include "loopd/base/scene_scale.hpp"
#include "loopd/base/sensor_estimate.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"
#include "support/data_dir.hpp"

using namespace loopd;

namespace {

PointCloud town_scan(const LidarModel& model, bool keep_rings) {
  static const Town town = make_town(7);
  PointCloud scan = simulate_scan(town, model, street_pose(town, 1, 1, 0, 20.0), 11, 2);
  if (!keep_rings) {
    scan.ring.clear();
    scan.num_rings = 0;
  }
  return scan;
}

double worst_angle_error(const LidarModel& truth, const LidarModel& seen) {
  double worst = 0.0;
  for (int i = 0; i < truth.num_rings; ++i) worst = std::max(worst, std::abs(truth.vertical_angles_deg[i] - seen.vertical_angles_deg[i]));
  return worst;
}

}  // namespace

TEST_CASE("auto: the beams of every preset are found in a scan without ring indices") {
  for (const std::string& name : lidar_model_names()) {
    const LidarModel truth = *lidar_model_from_name(name);
    CAPTURE(name);
    REQUIRE(truth.pattern == LidarModel::ScanPattern::kSpinning);
    const SensorEstimate est = estimate_sensor(town_scan(truth, false));
    REQUIRE(est.ok);
    CHECK(est.rings_resolved);
    CHECK_FALSE(est.rings_from_scan);
    CHECK(est.azimuth_coverage_deg >= 350.0);
    // Upper beams that see only sky leave no return: every beam with returns is found, at its elevation.
    REQUIRE(est.model.num_rings <= truth.num_rings);
    CHECK(est.model.num_rings >= truth.num_rings * 3 / 4);
    if (est.model.num_rings == truth.num_rings) {
      CHECK(worst_angle_error(truth, est.model) < 0.5);
      CHECK(est.model.azimuth_steps == Approx(truth.azimuth_steps).epsilon(0.1));  // the preset it matches, or counted
    }
    CHECK_FALSE(est.model.validate().has_value());
  }
}

TEST_CASE("auto: a scan's ring field gives the rings and the preset's datasheet angles") {
  const LidarModel truth = lidar_model_hdl64();
  const SensorEstimate est = estimate_sensor(town_scan(truth, true));
  REQUIRE(est.ok);
  CHECK(est.rings_from_scan);
  CHECK(est.model.num_rings == 64);
  CHECK(est.model.vertical_angles_deg == truth.vertical_angles_deg);
  CHECK(est.model.azimuth_steps == truth.azimuth_steps);
  CHECK(est.describe().find("64 rings between -24.9 and +2.0 deg") != std::string::npos);
  CHECK(est.describe().find("like hdl64") != std::string::npos);
}

TEST_CASE("auto: a non-repetitive narrow scan gets even rows over its own field of view") {
  // Returns scattered over a 70 x 70 deg cone ahead (no two at one elevation): no beams to find.
  PointCloud scan;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> az(-35.f, 35.f), el(-35.f, 35.f), range(3.f, 30.f);
  for (int i = 0; i < 5000; ++i) {
    const float a = az(rng) * static_cast<float>(M_PI) / 180.f, e = el(rng) * static_cast<float>(M_PI) / 180.f, r = range(rng);
    scan.points.emplace_back(r * std::cos(e) * std::cos(a), r * std::cos(e) * std::sin(a), r * std::sin(e));
  }
  const SensorEstimate est = estimate_sensor(scan);
  REQUIRE(est.ok);
  CHECK_FALSE(est.rings_resolved);
  CHECK(est.azimuth_coverage_deg == Approx(70.0).margin(3.0));
  CHECK(est.elevation_min_deg == Approx(-35.0).margin(1.0));
  CHECK(est.elevation_max_deg == Approx(35.0).margin(1.0));
  // Rows twice a square pixel of 0.4 returns tall: sqrt(70 x 70 x 0.4 / 5000) = 0.63 deg -> 1.25 deg, 56 rows over 70 deg;
  // 0.4 returns a pixel over the 70 deg seen: 5000 / (0.4 * 56) * 360 / 70 = 1148 columns a revolution.
  CHECK(est.model.num_rings == 56);
  CHECK(est.model.azimuth_steps == Approx(1148).epsilon(0.06));
  CHECK(est.describe().rfind("no ring pattern: 56 rows", 0) == 0);
}

TEST_CASE("a preset that does not fit the scans is reported in one sentence") {
  const SensorEstimate os0 = estimate_sensor(town_scan(lidar_model_ouster(0, 64), false));
  REQUIRE(os0.ok);
  const auto wrong = preset_mismatch(lidar_model_os1_64(), os0);
  REQUIRE(wrong.has_value());
  CHECK(wrong->find("--sensor os1-64 expects 64 between -16.6 and +16.6") != std::string::npos);
  CHECK(wrong->rfind("scans have ", 0) == 0);
  // The right preset fits; so does the preset of the scan's own ring field.
  CHECK_FALSE(preset_mismatch(lidar_model_ouster(0, 64), os0).has_value());
  CHECK_FALSE(preset_mismatch(lidar_model_hdl64(), estimate_sensor(town_scan(lidar_model_hdl64(), true))).has_value());
  // A fan much narrower than the preset's (an OS2 read as an OS0).
  CHECK(preset_mismatch(lidar_model_ouster(0, 64), estimate_sensor(town_scan(lidar_model_ouster(2, 64), false))).has_value());
}

TEST_CASE("sensor choices: auto, presets, a custom table, unknown names are refused with the list") {
  CHECK_FALSE(validate_sensor_choice("auto").has_value());
  CHECK_FALSE(validate_sensor_choice("os0-128").has_value());
  CHECK_FALSE(sensor_model_from_choice("auto").has_value());
  const auto bad = validate_sensor_choice("os9");
  REQUIRE(bad.has_value());
  CHECK(bad->find("unknown lidar model 'os9'") != std::string::npos);
  CHECK(bad->find("vlp32c") != std::string::npos);
  CHECK(validate_sensor_choice("custom").has_value());
  CHECK(validate_sensor_choice("custom", {-10.0, 0.0, 5.0, 4.0}).has_value());  // not ascending
  const auto custom = sensor_model_from_choice("custom", {-10.0, 0.0, 10.0}, 512);
  REQUIRE(custom.has_value());
  CHECK(custom->num_rings == 3);
  CHECK(custom->azimuth_steps == 512);
}

TEST_CASE("bad scans give an error, never a model") {
  PointCloud empty;
  CHECK_FALSE(estimate_sensor(empty).ok);
  PointCloud nan;
  nan.points.assign(1000, Eigen::Vector3f::Constant(std::nanf("")));
  const SensorEstimate e = estimate_sensor(nan);
  CHECK_FALSE(e.ok);
  CHECK(e.error.find("0 returns") != std::string::npos);
  CHECK(scene_scale(nan) == 0.0);
}

TEST_CASE("scene scale: rooms are metres, streets tens of metres") {
  const PointCloud street = town_scan(lidar_model_hdl64(), true);
  CHECK(scene_scale(street) > 8.0);
  const Town corridor = make_corridor();
  const PointCloud inside = simulate_scan(corridor, lidar_model_vlp16(), ground_pose(corridor, 10.0, 0.0, 0.0), 5, 2);
  CHECK(scene_scale(inside) < scene_scale(street));
}

TEST_CASE("real scans: an OS0-like handheld scan and a KITTI HDL-64E scan", "[real]") {
  LOOPD_REQUIRE_DATA(balm, "real/balm/000050.bin");
  const CloudFile os0 = read_cloud_file(balm);
  REQUIRE(os0.ok);
  const SensorEstimate est = estimate_sensor(os0.cloud);
  REQUIRE(est.ok);
  INFO(est.describe());
  CHECK(est.elevation_min_deg < -35.0);  // about +-45 deg: an OS1 preset (+-16.6) would put most returns off its fan
  CHECK(est.elevation_max_deg > 35.0);
  CHECK(preset_mismatch(lidar_model_os1_64(), est).has_value());
  CHECK(scene_scale(os0.cloud) < 25.0);  // a courtyard: about 11 m
  LOOPD_REQUIRE_DATA(kitti, "kitti/seq00/000000.bin");
  const CloudFile hdl = read_cloud_file(kitti);
  REQUIRE(hdl.ok);
  const SensorEstimate k = estimate_sensor(hdl.cloud);
  REQUIRE(k.ok);
  INFO(k.describe());
  CHECK(k.elevation_min_deg < -20.0);
  CHECK(k.elevation_max_deg < 5.0);
  CHECK_FALSE(preset_mismatch(lidar_model_hdl64(), k).has_value());
  CHECK(scene_scale(hdl.cloud) > scene_scale(os0.cloud));  // a street
}
