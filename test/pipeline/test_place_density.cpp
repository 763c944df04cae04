// The retirement policy of area-bounded maps on hand-made places: which keyframes a newly looped keyframe makes
// redundant, and which it never touches (its own pass, other headings, a read-only map's keyframes).
#include <catch2/catch.hpp>

#include "loopd/pipeline/place_density.hpp"

using namespace loopd;

namespace {

PlaceKeyframe view(SessionId session, std::int64_t index, double x, double yaw_deg, double travelled, int loops) {
  PlaceKeyframe k;
  k.key = KeyframeKey{session, index};
  k.T_map_sensor = Eigen::Isometry3d::Identity();
  k.T_map_sensor.translation() = Eigen::Vector3d(x, 0.2, 0.0);
  k.T_map_sensor.linear() = Eigen::AngleAxisd(yaw_deg * 3.14159265358979 / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  k.travelled = travelled;
  k.loops = loops;
  return k;
}

}  // namespace

TEST_CASE("place density: the newest view and the best-connected stay, the other passes' views at the place retire") {
  PlaceDensityConfig config;  // keep 2
  const PlaceKeyframe newest = view(0, 900, 0.0, 3.0, 1800.0, 1);
  const std::vector<PlaceKeyframe> near = {
      view(0, 100, 0.4, 0.0, 200.0, 2),    // lap 1
      view(0, 350, -0.3, 5.0, 700.0, 6),   // lap 2: the best-connected
      view(0, 620, 0.9, -4.0, 1250.0, 2),  // lap 3: as connected as lap 1, newer
  };
  const PlaceDensityResult r = thin_place(newest, near, 1.5, config);
  CHECK(r.views == 3);
  CHECK(r.retire == std::vector<KeyframeKey>{{0, 620}, {0, 100}});  // the newer of the two equally connected first

  config.keep = 3;
  CHECK(thin_place(newest, near, 1.5, config).retire == std::vector<KeyframeKey>{{0, 100}});
  config.keep = 1;  // only the newest view
  CHECK(thin_place(newest, near, 1.5, config).retire.size() == 3);
}

TEST_CASE("place density: the keyframe's own pass, views turned away and a read-only map's keyframes are never retired") {
  const PlaceDensityConfig config;
  const PlaceKeyframe newest = view(1, 40, 0.0, 0.0, 80.0, 1);
  std::vector<PlaceKeyframe> near = {
      view(1, 39, -1.2, 0.0, 78.0, 0),  // own pass: 2 m of travel back (< 4 radii)
      view(1, 2, 0.5, 170.0, 4.0, 3),   // the street driven the other way
      view(0, 10, 0.2, 10.0, 20.0, 1),  // the map's session
      view(0, 500, -0.4, -20.0, 900.0, 4),
  };
  PlaceDensityResult r = thin_place(newest, near, 1.5, config);
  CHECK(r.views == 2);
  CHECK(r.retire == std::vector<KeyframeKey>{{0, 10}});

  // Localizing in a read-only map: its keyframes count (a place it already holds) but only the run's own retire.
  for (PlaceKeyframe& k : near) k.retirable = k.key.session == 1;
  near.push_back(view(1, 3, 0.1, 1.0, 6.0, 5));  // the run's own earlier pass, well connected
  r = thin_place(newest, near, 1.5, config);
  CHECK(r.views == 3);
  CHECK(r.retire == std::vector<KeyframeKey>{{1, 3}});
}

TEST_CASE("place density: bad settings are refused with the setting named") {
  PlaceDensityConfig c;
  CHECK_FALSE(c.validate());
  c.keep = 0;
  CHECK(c.validate().value_or("").find("retirement.keep") != std::string::npos);
  c = PlaceDensityConfig{};
  c.radius_per_spacing = 0.0;
  CHECK(c.validate().value_or("").find("retirement.radius_per_spacing") != std::string::npos);
  c = PlaceDensityConfig{};
  c.max_rotation_deg = 270.0;
  CHECK(c.validate().value_or("").find("retirement.max_rotation_deg") != std::string::npos);
}
