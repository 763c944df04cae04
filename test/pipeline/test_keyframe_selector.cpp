// Keyframe rule (Ren 2019, Sec. 3.3.2): distance, rotation or time since the last keyframe.
#include <catch2/catch.hpp>
#include <cmath>

#include "loopd/pipeline/keyframe_selector.hpp"

using namespace loopd;

namespace {
constexpr std::int64_t kSecond = 1'000'000;

Eigen::Isometry3d pose(double x, double yaw_deg = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, 0.5 * x, 0.0);
  T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}
}  // namespace

TEST_CASE("the first scan is a keyframe, then one per min_distance travelled") {
  KeyframeSelector s(KeyframeConfig{});  // 2 m, 15 deg, 10 s
  CHECK(s.accept(pose(0.0), 0));
  // (x, x/2): |d| = 1.118 x, so x = 1.75 -> 1.96 m (no), x = 1.8 -> 2.01 m (yes).
  CHECK_FALSE(s.accept(pose(1.75), kSecond / 10));
  CHECK(s.accept(pose(1.8), 2 * kSecond / 10));
  // Measured from the last keyframe, not from the previous scan.
  CHECK_FALSE(s.accept(pose(2.5), 3 * kSecond / 10));
  CHECK_FALSE(s.accept(pose(3.5), 4 * kSecond / 10));
  CHECK(s.accept(pose(3.6), 5 * kSecond / 10));
}

TEST_CASE("turning on the spot makes a keyframe at min_rotation_deg") {
  KeyframeSelector s(KeyframeConfig{});
  CHECK(s.accept(pose(0.0, 0.0), 0));
  CHECK_FALSE(s.accept(pose(0.0, 14.0), kSecond / 10));
  CHECK(s.accept(pose(0.0, 15.5), 2 * kSecond / 10));
  CHECK_FALSE(s.accept(pose(0.0, 1.0), 3 * kSecond / 10));  // 14.5 deg back
  CHECK(s.accept(pose(0.0, -0.5), 4 * kSecond / 10));       // 16 deg back
}

TEST_CASE("standing still makes a keyframe every max_interval, 0 disables the time rule") {
  KeyframeSelector s(KeyframeConfig{});
  CHECK(s.accept(pose(0.0), 0));
  CHECK_FALSE(s.accept(pose(0.0), 9 * kSecond));
  CHECK(s.accept(pose(0.0), 10 * kSecond));
  KeyframeConfig no_time;
  no_time.max_interval = 0.0;
  KeyframeSelector t(no_time);
  CHECK(t.accept(pose(0.0), 0));
  CHECK_FALSE(t.accept(pose(0.0), 1000 * kSecond));
}

TEST_CASE("keyframe config refuses negative and out-of-range thresholds") {
  KeyframeConfig c;
  CHECK_FALSE(c.validate());
  c.min_distance = -1.0;
  CHECK(c.validate());
  c = KeyframeConfig{};
  c.min_rotation_deg = 200.0;
  CHECK(c.validate());
  c = KeyframeConfig{};
  c.max_interval = std::nan("");
  CHECK(c.validate());
}

TEST_CASE("the distance rule scales with the scene, never below min_spacing, and the scale is computed only when it decides") {
  KeyframeConfig c;  // 2 m, spacing_per_scale 0.0667, min_spacing 1 m
  KeyframeSelector s(c);
  CHECK(s.spacing(15.0) == Approx(1.0005));
  CHECK(s.spacing(60.0) == Approx(2.0));  // a street: the configured 2 m
  CHECK(s.spacing(5.0) == Approx(1.0));   // a tunnel: min_spacing
  int asked = 0;
  const auto courtyard = [&asked] {
    ++asked;
    return 15.0;
  };
  CHECK(s.accept(pose(0.0), 0, courtyard));
  CHECK_FALSE(s.accept(pose(0.5), kSecond / 10, courtyard));  // 0.56 m: below min_spacing, no scale needed
  CHECK(asked == 0);
  CHECK(s.accept(pose(0.9), 2 * kSecond / 10, courtyard));  // 1.006 m >= 1.0005 m
  CHECK(asked == 1);
  CHECK(s.accept(pose(2.9), 3 * kSecond / 10, courtyard));  // 2.24 m: the 2 m rule alone
  CHECK(asked == 1);
  c.spacing_per_scale = 0.0;  // off: 2 m everywhere
  KeyframeSelector fixed(c);
  CHECK(fixed.accept(pose(0.0), 0, courtyard));
  CHECK_FALSE(fixed.accept(pose(1.7), kSecond / 10, courtyard));
  CHECK(asked == 1);
}
