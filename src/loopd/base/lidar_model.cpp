#include "loopd/base/lidar_model.hpp"

#include <algorithm>
#include <cmath>
#include "loopd/base/angles.hpp"

namespace loopd {
namespace {

/// n angles linearly spaced from lo to hi inclusive, appended to out.
void append_linear(double lo, double hi, int n, std::vector<double>* out) {
  for (int i = 0; i < n; ++i) {
    out->push_back(n == 1 ? lo : lo + (hi - lo) * static_cast<double>(i) / static_cast<double>(n - 1));
  }
}

}  // namespace

std::optional<std::string> LidarModel::validate() const {
  if (num_rings <= 0) return std::string("num_rings must be > 0");
  const bool spinning = pattern == ScanPattern::kSpinning;
  if (spinning && static_cast<int>(vertical_angles_deg.size()) != num_rings) return std::string("vertical_angles_deg must have num_rings entries");
  if (!spinning && vertical_angles_deg.size() != 2) return std::string("a pattern model's vertical_angles_deg is its lowest and highest elevation");
  if (!spinning && !(horizontal_fov_deg > 0.0 && horizontal_fov_deg <= 360.0)) return std::string("horizontal_fov_deg must be in (0, 360]");
  for (std::size_t i = 1; i < vertical_angles_deg.size(); ++i) {
    if (!(vertical_angles_deg[i] > vertical_angles_deg[i - 1])) return std::string("vertical_angles_deg must be strictly ascending");
  }
  if (azimuth_steps <= 0) return std::string("azimuth_steps must be > 0");
  if (!(min_range >= 0.0) || !(max_range > min_range)) return std::string("need 0 <= min_range < max_range");
  if (!(range_noise_sigma >= 0.0)) return std::string("range_noise_sigma must be >= 0");
  if (!(dropout_rate >= 0.0 && dropout_rate < 1.0)) return std::string("dropout_rate must be in [0, 1)");
  return std::nullopt;
}

LidarModel lidar_model_vlp16() {
  LidarModel m;
  m.name = "vlp16";
  m.num_rings = 16;
  // VLP-16 datasheet: vertical FOV 30 deg (+15 to -15), vertical resolution 2.0 deg.
  append_linear(-15.0, 15.0, 16, &m.vertical_angles_deg);
  // VLP-16 datasheet: horizontal resolution 0.1-0.4 deg; 0.2 deg at 10 Hz -> 1800 columns.
  m.azimuth_steps = 1800;
  // VLP-16 datasheet: range up to 100 m, accuracy +-3 cm (typical); returns closer than ~0.5 m are not reported.
  m.min_range = 0.5;
  m.max_range = 100.0;
  m.range_noise_sigma = 0.02;
  m.dropout_rate = 0.01;
  return m;
}

LidarModel lidar_model_hdl32() {
  LidarModel m;
  m.name = "hdl32";
  m.num_rings = 32;
  // HDL-32E datasheet: vertical FOV +10.67 to -30.67 deg, 32 lasers at ~1.33 deg spacing.
  append_linear(-30.67, 10.67, 32, &m.vertical_angles_deg);
  // HDL-32E: ~0.16 deg horizontal resolution at 10 Hz (~2170 firings per laser per revolution).
  m.azimuth_steps = 2170;
  // HDL-32E datasheet: range 80-100 m, accuracy <2 cm (1 sigma at 25 m).
  m.min_range = 1.0;
  m.max_range = 100.0;
  m.range_noise_sigma = 0.02;
  m.dropout_rate = 0.01;
  return m;
}

LidarModel lidar_model_hdl64() {
  LidarModel m;
  m.name = "hdl64";
  m.num_rings = 64;
  // HDL-64E S2 datasheet: vertical FOV +2.0 to -24.9 deg (26.9 deg), two blocks of 32 lasers:
  // the lower block covers -24.9..-8.87 deg (~1/2 deg spacing), the upper block -8.33..+2.0 deg (~1/3 deg spacing).
  // Linear spacing within each block approximates the per-unit calibration table.
  append_linear(-24.9, -8.87, 32, &m.vertical_angles_deg);
  append_linear(-8.33, 2.0, 32, &m.vertical_angles_deg);
  // HDL-64E: angular resolution 0.1728 deg at 10 Hz (0.08 deg at 5 Hz) -> 2083 columns.
  m.azimuth_steps = 2083;
  // HDL-64E datasheet: range 120 m (cars/foliage), accuracy <2 cm (1 sigma).
  m.min_range = 1.0;
  m.max_range = 120.0;
  m.range_noise_sigma = 0.02;
  m.dropout_rate = 0.01;
  return m;
}

LidarModel lidar_model_os1_64() {
  LidarModel m;
  m.name = "os1-64";
  m.num_rings = 64;
  // Ouster OS1-64 (gen 1) datasheet: vertical FOV 33.2 deg (+16.6 to -16.6), uniform beam spacing.
  append_linear(-16.6, 16.6, 64, &m.vertical_angles_deg);
  // OS1: horizontal resolution 512, 1024 or 2048 columns; 2048 at 10 Hz.
  m.azimuth_steps = 2048;
  // OS1 datasheet: range 120 m (80% reflectivity); range precision ~1.5-5 cm; min range ~0.8 m.
  m.min_range = 0.8;
  m.max_range = 120.0;
  m.range_noise_sigma = 0.02;
  m.dropout_rate = 0.01;
  return m;
}

LidarModel lidar_model_os1_64_1024() {
  LidarModel m = lidar_model_os1_64();
  m.name = "os1-64-1024";
  m.azimuth_steps = 1024;
  return m;
}

namespace {

/// An Ouster Rev6/7 sensor with uniform beam spacing over `fov_deg` (centred on the horizon), 1024 columns (10 Hz).
LidarModel ouster(const std::string& name, int beams, double fov_deg, double max_range) {
  LidarModel m;
  m.name = name;
  m.num_rings = beams;
  append_linear(-0.5 * fov_deg, 0.5 * fov_deg, beams, &m.vertical_angles_deg);
  m.azimuth_steps = 1024;
  m.min_range = 0.5;
  m.max_range = max_range;
  m.range_noise_sigma = 0.02;
  m.dropout_rate = 0.01;
  return m;
}

LidarModel spinning(const std::string& name, std::vector<double> angles, int columns, double max_range) {
  LidarModel m;
  m.name = name;
  m.num_rings = static_cast<int>(angles.size());
  m.vertical_angles_deg = std::move(angles);
  m.azimuth_steps = columns;
  m.min_range = 0.5;
  m.max_range = max_range;
  m.range_noise_sigma = 0.02;
  m.dropout_rate = 0.01;
  return m;
}

}  // namespace

// Ouster datasheets (Rev6/Rev7): OS0 90 deg vertical FOV, OS1 45 deg, OS2 22.5 deg; 32, 64 or 128 beams;
// 512/1024/2048 columns (1024 at 10 Hz here). Ranges: OS0 ~50 m, OS1 ~120 m, OS2 ~240 m (80 % reflectivity).
LidarModel lidar_model_ouster(int generation_fov_index, int beams) {
  static const char* names[] = {"os0", "os1", "os2"};
  static const double fov[] = {90.0, 45.0, 22.5}, range[] = {50.0, 120.0, 240.0};
  const int g = std::clamp(generation_fov_index, 0, 2);
  std::string name = std::string(names[g]) + "-" + std::to_string(beams);
  if (g == 1 && beams == 64) name = "os1-64-rev6";  // "os1-64" stays the gen-1 +-16.6 deg unit
  return ouster(name, beams, fov[g], range[g]);
}

LidarModel lidar_model_vlp32c() {
  // VLP-32C user manual, laser elevation table (-25..+15 deg, denser near the horizon); 0.2 deg at 10 Hz, 200 m.
  return spinning("vlp32c",
                  {-25.0,  -15.639, -11.31, -8.843, -7.254, -6.148, -5.333, -4.667, -4.0,  -3.667, -3.333, -3.0,  -2.667, -2.333, -2.0,   -1.667,
                   -1.333, -1.0,    -0.667, -0.333, 0.0,    0.333,  0.667,  1.0,    1.333, 1.667,  2.333,  3.333, 4.667,  7.0,    10.333, 15.0},
                  1800, 200.0);
}

LidarModel lidar_model_vls128() {
  // VLS-128 datasheet: -25..+15 deg, 0.11 deg finest spacing near the horizon, 0.2 deg at 10 Hz, 245 m. The per-laser
  // table is approximated by three linear blocks (sparse below, 0.11 deg in the middle, sparse above).
  std::vector<double> a;
  append_linear(-25.0, -6.0, 20, &a);
  append_linear(-5.8, 4.0, 90, &a);
  append_linear(4.4, 15.0, 18, &a);
  return spinning("vls128", std::move(a), 1800, 245.0);
}

LidarModel lidar_model_pandar64() {
  // Hesai Pandar64 datasheet: -25..+15 deg, 0.167 deg finest between -6 and +2 deg; 0.2 deg at 10 Hz; 200 m.
  // Approximated by three linear blocks.
  std::vector<double> a;
  append_linear(-25.0, -7.0, 8, &a);
  append_linear(-6.0, 2.0, 48, &a);
  append_linear(3.0, 15.0, 8, &a);
  return spinning("pandar64", std::move(a), 1800, 200.0);
}

LidarModel lidar_model_pandar_xt32() {
  // Hesai PandarXT-32 datasheet: 32 beams, -16..+15 deg at 1 deg, 0.18 deg at 10 Hz (2000 columns), 120 m.
  std::vector<double> a;
  append_linear(-16.0, 15.0, 32, &a);
  return spinning("pandar-xt32", std::move(a), 2000, 120.0);
}

LidarModel lidar_model_avia() {
  LidarModel m;
  m.name = "avia";
  m.pattern = LidarModel::ScanPattern::kRosette;
  m.num_rings = 6;
  m.vertical_angles_deg = {-38.6, 38.6};
  m.horizontal_fov_deg = 70.4;
  m.azimuth_steps = 4000;  // 6 x 4000 = 24,000 returns a scan at 10 Hz
  m.min_range = 1.0;
  m.max_range = 200.0;  // the town's extent; the sensor reaches 450 m
  m.range_noise_sigma = 0.02;
  m.dropout_rate = 0.01;
  return m;
}

LidarModel lidar_model_mid360() {
  LidarModel m;
  m.name = "mid360";
  m.pattern = LidarModel::ScanPattern::kSpinningNonRepetitive;
  m.num_rings = 4;
  m.vertical_angles_deg = {-7.0, 52.0};
  m.azimuth_steps = 5000;  // 4 x 5000 = 20,000 returns a scan at 10 Hz
  m.min_range = 0.1;
  m.max_range = 70.0;
  m.range_noise_sigma = 0.02;
  m.dropout_rate = 0.01;
  return m;
}

std::vector<std::string> lidar_pattern_model_names() { return {"avia", "mid360"}; }

std::optional<LidarModel> lidar_model_from_name(const std::string& name) {
  if (name == "vlp16") return lidar_model_vlp16();
  if (name == "hdl32") return lidar_model_hdl32();
  if (name == "hdl64") return lidar_model_hdl64();
  if (name == "os1-64") return lidar_model_os1_64();
  if (name == "os1-64-1024") return lidar_model_os1_64_1024();
  if (name == "vlp32c") return lidar_model_vlp32c();
  if (name == "vls128") return lidar_model_vls128();
  if (name == "pandar64") return lidar_model_pandar64();
  if (name == "pandar-xt32") return lidar_model_pandar_xt32();
  if (name == "avia") return lidar_model_avia();
  if (name == "mid360") return lidar_model_mid360();
  for (int g = 0; g < 3; ++g) {
    for (const int beams : {32, 64, 128}) {
      const LidarModel m = lidar_model_ouster(g, beams);
      if (m.name == name) return m;
    }
  }
  return std::nullopt;
}

std::vector<std::string> lidar_model_names() {
  return {"vlp16",   "vlp32c", "hdl32",       "hdl64",   "vls128", "os1-64", "os1-64-1024", "os0-32",   "os0-64",
          "os0-128", "os1-32", "os1-64-rev6", "os1-128", "os2-32", "os2-64", "os2-128",     "pandar64", "pandar-xt32"};
}

int ring_from_elevation(const LidarModel& model, double elevation_rad) {
  const auto& a = model.vertical_angles_deg;
  if (a.empty() || !std::isfinite(elevation_rad)) return -1;
  const double e = elevation_rad * 180.0 / kPi;
  // Tolerance beyond the outermost rings: half the adjacent spacing (or 1 deg for a single ring).
  const double lo_tol = a.size() > 1 ? 0.5 * (a[1] - a[0]) : 1.0;
  const double hi_tol = a.size() > 1 ? 0.5 * (a[a.size() - 1] - a[a.size() - 2]) : 1.0;
  if (e < a.front() - lo_tol || e > a.back() + hi_tol) return -1;
  auto it = std::lower_bound(a.begin(), a.end(), e);
  if (it == a.end()) return static_cast<int>(a.size()) - 1;
  if (it == a.begin()) return 0;
  const auto hi = it - a.begin();
  return (e - a[static_cast<std::size_t>(hi - 1)] <= a[static_cast<std::size_t>(hi)] - e) ? static_cast<int>(hi - 1) : static_cast<int>(hi);
}

}  // namespace loopd
