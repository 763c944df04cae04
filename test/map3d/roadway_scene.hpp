#pragma once
// Synthetic mine roadways for the map-cleaning tests and the hand benchmark: a straight tunnel along +x (floor z = 0,
// walls y = +-width/2, flat or arched roof), optionally a 5 m opening in the left wall with a side tunnel behind it, or
// an open street (no roof); surfaces sampled on a grid with uniform jitter; dust and a person-sized box inside; the
// keyframe trajectory along the centre line at sensor height.
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace roadway_scene {

enum Label : std::uint8_t {
  kSurface = 0,           // roadway floor, walls, roof
  kSideTunnel = 1,        // surfaces of the side tunnel, behind the main tunnel's left wall
  kNoise = 2,             // dust and person points at least 0.3 m off every surface
  kNoiseNearSurface = 3,  // person points within 0.3 m of the floor
};

struct Spec {
  double x_begin = -5, x_end = 65;  // [m] tunnel extent (the trajectory runs 0..track_end)
  double track_end = 60;            // [m]
  double width = 5, height = 4.5;   // [m]
  bool arched = false;              // walls to arch_spring, then a circular arch up to height
  double arch_spring = 3.5;         // [m]
  bool roof = true;                 // false: an open street (floor and walls of street_wall_height)
  double street_wall_height = 6;    // [m]
  bool side_opening = false;        // left wall open over [opening_begin, opening_end], a side tunnel behind
  double opening_begin = 30, opening_end = 35, side_length = 20;
  double spacing = 0.05, jitter = 0.02;  // [m]
  int dust = 500;
  bool person = true;
  double keyframe_step = 2.0, sensor_height = 1.8;  // [m]
  unsigned seed = 7;
};

struct Scene {
  loopd::PointCloud map;
  std::vector<std::uint8_t> label;  // one per map point
  std::vector<Eigen::Isometry3d> T_world_keyframe;
};

class Builder {
 public:
  explicit Builder(const Spec& spec) : spec_(spec), rng_(spec.seed), jitter_(-spec.jitter, spec.jitter) {}

  Scene build() {
    const double half = spec_.width / 2, wall_top = !spec_.roof ? spec_.street_wall_height : spec_.arched ? spec_.arch_spring : spec_.height;
    for (double x = spec_.x_begin; x <= spec_.x_end; x += spec_.spacing) {
      const bool open = spec_.side_opening && x > spec_.opening_begin && x < spec_.opening_end;
      for (double y = -half; y <= half; y += spec_.spacing) add(x, y, 0, kSurface);
      for (double z = spec_.spacing; z <= wall_top; z += spec_.spacing) {
        if (!open) add(x, half, z, kSurface);
        add(x, -half, z, kSurface);
      }
      if (spec_.roof && !spec_.arched) {
        for (double y = -half; y <= half; y += spec_.spacing) add(x, y, spec_.height, kSurface);
      }
      if (spec_.roof && spec_.arched) add_arch(x);
    }
    if (spec_.side_opening) add_side_tunnel();
    add_noise();
    for (double x = 0; x <= spec_.track_end + 1e-9; x += spec_.keyframe_step) {
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.translation() = Eigen::Vector3d(x, 0, spec_.sensor_height);
      scene_.T_world_keyframe.push_back(T);
    }
    return std::move(scene_);
  }

 private:
  void add(double x, double y, double z, Label label) {
    scene_.map.points.emplace_back(static_cast<float>(x + jitter_(rng_)), static_cast<float>(y + jitter_(rng_)),
                                   static_cast<float>(z + jitter_(rng_)));
    scene_.map.intensity.push_back(static_cast<float>(label));
    scene_.label.push_back(label);
  }

  // A circular arch through (+-width/2, arch_spring) and (0, height).
  void add_arch(double x) {
    const double half = spec_.width / 2, rise = spec_.height - spec_.arch_spring;
    const double radius = (half * half + rise * rise) / (2 * rise), centre_z = spec_.height - radius;
    const double max_angle = std::asin(half / radius);
    for (double t = -max_angle; t <= max_angle; t += spec_.spacing / radius) add(x, radius * std::sin(t), centre_z + radius * std::cos(t), kSurface);
  }

  void add_side_tunnel() {
    const double half = spec_.width / 2, y_end = half + spec_.side_length, s = spec_.spacing;
    for (double y = half + s; y <= y_end; y += s) {
      for (double z = 0; z <= spec_.height; z += s) {
        add(spec_.opening_begin, y, z, kSideTunnel);
        add(spec_.opening_end, y, z, kSideTunnel);
      }
      for (double x = spec_.opening_begin + s; x < spec_.opening_end; x += s) {
        add(x, y, 0, kSideTunnel);
        add(x, y, spec_.height, kSideTunnel);
      }
    }
  }

  void add_noise() {
    const double half = spec_.width / 2, margin = 0.3;
    const double top = (!spec_.roof ? spec_.street_wall_height : spec_.arched ? spec_.arch_spring : spec_.height) - margin;
    std::uniform_real_distribution<double> x(0.5, spec_.track_end - 0.5), y(-half + margin, half - margin), z(margin, top);
    for (int i = 0; i < spec_.dust; ++i) add(x(rng_), y(rng_), z(rng_), kNoise);
    if (!spec_.person) return;
    // A standing person: the sides and top of a 0.5 x 0.5 x 1.7 m box on the floor, 20 m in, left of the centre line.
    const double x0 = 20, y0 = 0.5, side = 0.5, tall = 1.7, s = spec_.spacing;
    for (double z = 0; z <= tall; z += s) {
      const Label label = z >= margin ? kNoise : kNoiseNearSurface;
      for (double t = 0; t < side; t += s) {
        add(x0 + t, y0, z, label);
        add(x0 + side, y0 + t, z, label);
        add(x0 + side - t, y0 + side, z, label);
        add(x0, y0 + side - t, z, label);
      }
    }
    for (double u = s; u < side; u += s) {
      for (double v = s; v < side; v += s) add(x0 + u, y0 + v, tall, kNoise);
    }
  }

  Spec spec_;
  std::mt19937 rng_;
  std::uniform_real_distribution<double> jitter_;
  Scene scene_;
};

inline Scene build(const Spec& spec) { return Builder(spec).build(); }

}  // namespace roadway_scene
