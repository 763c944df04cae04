#include "loopd/sim/lidar_sim.hpp"

#include "loopd/sim/scan_pattern.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>
#include "loopd/base/angles.hpp"

namespace loopd {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kGround = -1;
constexpr int kNone = -2;

struct Ray {
  Eigen::Vector3d o, d, inv;
};

struct Hit {
  double t = kInf;
  int prim = kNone;
};

/// Ground plane z = z0 + gx x + gy y; only hit from above.
double intersect_ground(const Town& town, const Ray& r) {
  const double denom = r.d.z() - town.ground_gx * r.d.x() - town.ground_gy * r.d.y();
  if (denom >= -1e-12) return kInf;
  const double t = (town.ground_height(r.o.x(), r.o.y()) - r.o.z()) / denom;
  return t > 0.0 ? t : kInf;
}

double intersect_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Ray& r, double t_best) {
  double t0 = 0.0, t1 = t_best;
  for (int k = 0; k < 3; ++k) {
    double a = (lo[k] - r.o[k]) * r.inv[k];
    double b = (hi[k] - r.o[k]) * r.inv[k];
    if (a > b) std::swap(a, b);
    if (a > t0) t0 = a;
    if (b < t1) t1 = b;
    if (t0 > t1) return kInf;
  }
  return t0 > 1e-9 ? t0 : kInf;  // origin inside the box: no return
}

double intersect_cylinder(const Primitive& p, const Ray& r, double t_best) {
  const double ox = r.o.x() - p.a.x(), oy = r.o.y() - p.a.y();
  const double A = r.d.x() * r.d.x() + r.d.y() * r.d.y();
  const double rr = p.radius * p.radius;
  double t = kInf;
  if (A > 1e-12) {
    const double B = ox * r.d.x() + oy * r.d.y();
    const double C = ox * ox + oy * oy - rr;
    const double disc = B * B - A * C;
    if (disc < 0.0) return kInf;
    const double t1 = (-B - std::sqrt(disc)) / A;
    if (t1 > 1e-9 && t1 < t_best) {
      const double z = r.o.z() + t1 * r.d.z();
      if (z >= p.a.z() && z <= p.b.z()) return t1;
    }
  }
  // Top cap.
  if (r.d.z() < 0.0 && r.o.z() > p.b.z()) {
    const double tc = (p.b.z() - r.o.z()) / r.d.z();
    const double x = ox + tc * r.d.x(), y = oy + tc * r.d.y();
    if (x * x + y * y <= rr && tc < t_best) t = tc;
  }
  return t;
}

double intersect_sphere(const Primitive& p, const Ray& r) {
  const Eigen::Vector3d oc = r.o - p.a;
  const double B = oc.dot(r.d);
  const double C = oc.squaredNorm() - p.radius * p.radius;
  const double disc = B * B - C;
  if (disc < 0.0) return kInf;
  const double t = -B - std::sqrt(disc);
  return t > 1e-9 ? t : kInf;
}

/// Raised patch: top at ground + h over [a.x, b.x] x [a.y, b.y]; vertical kerb faces on the four sides.
double intersect_slab(const Town& town, const Primitive& p, const Ray& r, double t_best) {
  const double h = p.a.z();
  double best = kInf;
  const double denom = r.d.z() - town.ground_gx * r.d.x() - town.ground_gy * r.d.y();
  if (denom < -1e-12) {
    const double t = (town.ground_height(r.o.x(), r.o.y()) + h - r.o.z()) / denom;
    if (t > 1e-9 && t < t_best) {
      const double x = r.o.x() + t * r.d.x(), y = r.o.y() + t * r.d.y();
      if (x >= p.a.x() && x <= p.b.x() && y >= p.a.y() && y <= p.b.y()) best = t;
    }
  }
  for (int axis = 0; axis < 2; ++axis) {
    if (std::abs(r.d[axis]) < 1e-12) continue;
    const int other = 1 - axis;
    for (double plane : {p.a[axis], p.b[axis]}) {
      const double t = (plane - r.o[axis]) * r.inv[axis];
      if (!(t > 1e-9 && t < std::min(best, t_best))) continue;
      const double u = r.o[other] + t * r.d[other];
      if (u < p.a[other] || u > p.b[other]) continue;
      const double x = r.o.x() + t * r.d.x(), y = r.o.y() + t * r.d.y(), z = r.o.z() + t * r.d.z();
      const double g = town.ground_height(x, y);
      if (z >= g && z <= g + h) best = t;
    }
  }
  return best;
}

double intersect(const Town& town, const Primitive& p, const Ray& r, double t_best) {
  switch (p.type) {
    case PrimitiveType::kBox:
      return intersect_box(p.a, p.b, r, t_best);
    case PrimitiveType::kCylinder:
      return intersect_cylinder(p, r, t_best);
    case PrimitiveType::kSphere:
      return intersect_sphere(p, r);
    case PrimitiveType::kSlab:
      return intersect_slab(town, p, r, t_best);
  }
  return kInf;
}

/// Nearest hit along the ray up to max_range: the ground plane, then the primitives of the grid cells on the ray's path.
Hit trace(const Town& town, const std::vector<std::uint8_t>& enabled, const Ray& r, double max_range) {
  Hit hit;
  const double tg = intersect_ground(town, r);
  if (tg < max_range) {
    hit.t = tg;
    hit.prim = kGround;
  }
  double t_end = std::min(hit.t, max_range);
  // Above every primitive: nothing more to find.
  if (r.d.z() > 1e-12) t_end = std::min(t_end, std::max(0.0, (town.max_z - r.o.z()) / r.d.z()));
  if (town.grid_nx <= 0 || town.primitives.empty()) return hit;

  // Clip the ray to the grid rectangle.
  const double cs = town.cell_size;
  const double gx1 = town.grid_x0 + cs * town.grid_nx, gy1 = town.grid_y0 + cs * town.grid_ny;
  double t0 = 0.0, t1 = t_end;
  const double lo[2] = {town.grid_x0, town.grid_y0}, hi[2] = {gx1, gy1};
  for (int k = 0; k < 2; ++k) {
    if (std::abs(r.d[k]) < 1e-15) {
      if (r.o[k] < lo[k] || r.o[k] > hi[k]) return hit;
      continue;
    }
    double a = (lo[k] - r.o[k]) * r.inv[k], b = (hi[k] - r.o[k]) * r.inv[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  if (t0 > t1) return hit;

  const double sx = r.o.x() + t0 * r.d.x(), sy = r.o.y() + t0 * r.d.y();
  int ix = std::clamp(static_cast<int>(std::floor((sx - town.grid_x0) / cs)), 0, town.grid_nx - 1);
  int iy = std::clamp(static_cast<int>(std::floor((sy - town.grid_y0) / cs)), 0, town.grid_ny - 1);
  const int step_x = r.d.x() > 0 ? 1 : -1, step_y = r.d.y() > 0 ? 1 : -1;
  const double dx_abs = std::abs(r.d.x()), dy_abs = std::abs(r.d.y());
  double t_next_x = dx_abs > 1e-15 ? (town.grid_x0 + (ix + (step_x > 0 ? 1 : 0)) * cs - r.o.x()) / r.d.x() : kInf;
  double t_next_y = dy_abs > 1e-15 ? (town.grid_y0 + (iy + (step_y > 0 ? 1 : 0)) * cs - r.o.y()) / r.d.y() : kInf;
  const double dt_x = dx_abs > 1e-15 ? cs / dx_abs : kInf, dt_y = dy_abs > 1e-15 ? cs / dy_abs : kInf;

  // Mailbox: primitives spanning several cells (blocks, buildings) are tested once per ray.
  constexpr int kMailbox = 16;
  std::uint32_t tested[kMailbox];
  int num_tested = 0;
  while (true) {
    const std::size_t cell = static_cast<std::size_t>(iy) * static_cast<std::size_t>(town.grid_nx) + static_cast<std::size_t>(ix);
    for (std::uint32_t k = town.cell_start[cell]; k < town.cell_start[cell + 1]; ++k) {
      const std::uint32_t pi = town.cell_items[k];
      if (!enabled[pi]) continue;
      bool seen = false;
      for (int q = 0; q < std::min(num_tested, kMailbox); ++q) seen |= tested[q] == pi;
      if (seen) continue;
      tested[num_tested++ % kMailbox] = pi;
      const double t = intersect(town, town.primitives[pi], r, hit.t);
      if (t < hit.t && t < max_range) {
        hit.t = t;
        hit.prim = static_cast<int>(pi);
      }
    }
    const double t_exit = std::min(t_next_x, t_next_y);
    if (hit.t <= t_exit || t_exit >= t1) break;
    if (t_next_x < t_next_y) {
      ix += step_x;
      t_next_x += dt_x;
      if (ix < 0 || ix >= town.grid_nx) break;
    } else {
      iy += step_y;
      t_next_y += dt_y;
      if (iy < 0 || iy >= town.grid_ny) break;
    }
  }
  return hit;
}

/// True when a hit on a facade box falls on a window pane (1.4 m x 1.2 m panes on a 3 m grid, above 3 m).
bool on_window(const Primitive& p, const Eigen::Vector3d& x, const Eigen::Vector3d& n) {
  if (!p.windows || n.z() != 0.0) return false;
  const double z = x.z() - (p.a.z() + 2.0);  // box bottoms are sunk 2 m below the lot
  if (z < 3.0 || z > p.b.z() - p.a.z() - 2.5) return false;
  const double u = n.x() != 0.0 ? x.y() - p.a.y() : x.x() - p.a.x();
  const double fu = std::fmod(u, 3.0), fz = std::fmod(z, 3.0);
  return fu > 0.8 && fu < 2.2 && fz > 1.0 && fz < 2.2;
}

/// Surface normal and reflectivity at a hit; `glass` set when the hit is on a window.
void surface(const Town& town, const Ray& r, const Hit& hit, Eigen::Vector3d* n, double* refl, bool* glass) {
  *glass = false;
  const Eigen::Vector3d x = r.o + hit.t * r.d;
  if (hit.prim == kGround) {
    *n = Eigen::Vector3d(-town.ground_gx, -town.ground_gy, 1.0).normalized();
    *refl = 0.12;
    if (town.lane_markings) {
      // Dashed centre lines (3 m paint, 3 m gap), 0.15 m wide: bright road marking.
      auto near_line = [](const std::vector<double>& lines, double v) {  // lines are sorted
        auto it = std::lower_bound(lines.begin(), lines.end(), v - 0.075);
        return it != lines.end() && *it <= v + 0.075;
      };
      if ((near_line(town.street_x, x.x()) && std::fmod(std::abs(x.y()), 6.0) < 3.0) ||
          (near_line(town.street_y, x.y()) && std::fmod(std::abs(x.x()), 6.0) < 3.0)) {
        *refl = 0.8;
      }
    }
    return;
  }
  const Primitive& p = town.primitives[static_cast<std::size_t>(hit.prim)];
  *refl = p.reflectivity;
  switch (p.type) {
    case PrimitiveType::kBox: {
      // Face whose plane is nearest to the hit point.
      double best = kInf;
      int axis = 2;
      double sign = 1.0;
      for (int k = 0; k < 3; ++k) {
        const double dl = std::abs(x[k] - p.a[k]), dh = std::abs(x[k] - p.b[k]);
        if (dl < best) best = dl, axis = k, sign = -1.0;
        if (dh < best) best = dh, axis = k, sign = 1.0;
      }
      *n = Eigen::Vector3d::Zero();
      (*n)[axis] = sign;
      *glass = on_window(p, x, *n);
      break;
    }
    case PrimitiveType::kCylinder: {
      if (x.z() >= p.b.z() - 1e-6) {
        *n = Eigen::Vector3d::UnitZ();
      } else {
        *n = Eigen::Vector3d(x.x() - p.a.x(), x.y() - p.a.y(), 0.0).normalized();
      }
      break;
    }
    case PrimitiveType::kSphere:
      *n = (x - p.a).normalized();
      break;
    case PrimitiveType::kSlab: {
      const double g = town.ground_height(x.x(), x.y());
      if (x.z() >= g + p.a.z() - 1e-6) {
        *n = Eigen::Vector3d(-town.ground_gx, -town.ground_gy, 1.0).normalized();
      } else {
        const double dx = std::min(std::abs(x.x() - p.a.x()), std::abs(x.x() - p.b.x()));
        const double dy = std::min(std::abs(x.y() - p.a.y()), std::abs(x.y() - p.b.y()));
        *n = dx < dy ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
      }
      break;
    }
  }
}

/// Primitives a ray can hit on `visit`: the movable objects in their state of that visit; bushes only with vegetation.
std::vector<std::uint8_t> enabled_for_visit(const Town& town, int visit, bool vegetation) {
  std::vector<std::uint8_t> enabled(town.primitives.size(), 1);
  for (std::size_t k = 0; k < town.primitives.size(); ++k) {
    const Primitive& p = town.primitives[k];
    if (p.movable_id >= 0) enabled[k] = town.active_variant(p.movable_id, visit) == p.variant ? 1 : 0;
    if (p.bush && !vegetation) enabled[k] = 0;
  }
  return enabled;
}

Ray make_ray(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  Ray r;
  r.o = o;
  r.d = d;
  for (int k = 0; k < 3; ++k) r.inv[k] = std::abs(d[k]) > 1e-15 ? 1.0 / d[k] : (d[k] >= 0 ? 1e300 : -1e300);
  return r;
}

// Random streams of one ray, all drawn from its hash h = hash(seed, ray): h itself decides the model's dropout and
// mix64(h + 1) the range noise (as before the sensor effects existed); the effects draw from these.
constexpr std::uint64_t kDropoutStream = 0xD50F7A11ull;
constexpr std::uint64_t kFoliageStream = 0xF011A6E5ull;
constexpr int kMaxFoliagePasses = 4;  ///< foliage a ray may pass through before it is given up
constexpr double kMaxDropout = 0.95;

/// Distance along the ray to where it leaves sphere p.
double sphere_exit(const Primitive& p, const Ray& r) {
  const Eigen::Vector3d oc = r.o - p.a;
  const double B = oc.dot(r.d);
  const double C = oc.squaredNorm() - p.radius * p.radius;
  return -B + std::sqrt(std::max(0.0, B * B - C));
}

/// The nearest hit with porous foliage: a ray entering a vegetation sphere returns from inside it with probability
/// 1 - exp(-density * chord), at depth -ln(1 - u) / density for the draw u that decided it (the Beer-Lambert depth
/// given a return within the chord), unless something solid inside (a trunk) comes first; else it goes on.
Hit trace_foliage(const Town& town, const std::vector<std::uint8_t>& enabled, const Ray& r, double max_range, double density, std::uint64_t h) {
  Ray cur = r;
  double travelled = 0.0;
  Hit hit = trace(town, enabled, cur, max_range);
  for (int pass = 0; pass < kMaxFoliagePasses; ++pass) {
    if (hit.prim < 0 || !town.primitives[static_cast<std::size_t>(hit.prim)].vegetation) {
      if (hit.prim != kNone) hit.t += travelled;
      return hit;
    }
    const int foliage = hit.prim;
    const double chord = std::max(0.0, sphere_exit(town.primitives[static_cast<std::size_t>(foliage)], cur) - hit.t);
    const double u = detail::hash_uniform(detail::mix64(h ^ (kFoliageStream + static_cast<std::uint64_t>(pass))));
    const double depth = u < 1.0 - std::exp(-density * chord) ? -std::log1p(-u) / density : kInf;
    // Go on from just inside the foliage: its sphere is not hit from inside, what stands in it is.
    const double enter = hit.t + 1e-6;
    travelled += enter;
    if (travelled >= max_range) break;
    cur = make_ray(cur.o + enter * cur.d, cur.d);
    hit = trace(town, enabled, cur, max_range - travelled);
    if (depth < hit.t && travelled + depth < max_range) {
      Hit leaf;
      leaf.t = travelled + depth;
      leaf.prim = foliage;
      return leaf;
    }
  }
  return Hit{};
}

/// Probability that SensorEffects::dropouts loses a return.
double effect_dropout(const SensorEffects& fx, double rel_range, double cos_inc, double reflectivity) {
  const double grazing = 1.0 - cos_inc;
  const double dark = std::max(0.0, 0.5 - reflectivity) / 0.5;
  const double p = fx.dropout_rate * (1.0 + fx.dropout_range_gain * rel_range * rel_range) * (1.0 + fx.dropout_grazing_gain * grazing * grazing) *
                   (1.0 + fx.dropout_dark_gain * dark);
  return std::min(p, kMaxDropout);
}

/// What a sweep needs once: beam direction tables, each column's sensor pose and time, the primitives visible.
struct Sweep {
  std::vector<double> cos_el, sin_el, cos_az, sin_az;
  std::vector<Eigen::Matrix3d> R;  ///< world rotation of the sensor per column (one entry without motion skew)
  std::vector<Eigen::Vector3d> o;  ///< world position of the sensor, likewise
  std::vector<float> time;         ///< [s] measurement time of each column relative to the stamp
  std::vector<std::uint8_t> enabled;
};

Sweep make_sweep(const Town& town, const LidarModel& model, const SensorPoseAt& pose_at, double period, const SensorEffects& fx, int visit) {
  Sweep s;
  const int rings = model.num_rings, cols = model.azimuth_steps;
  for (int r = 0; r < rings; ++r) {
    const double e = model.vertical_angles_deg[static_cast<std::size_t>(r)] * kPi / 180.0;
    s.cos_el.push_back(std::cos(e));
    s.sin_el.push_back(std::sin(e));
  }
  for (int c = 0; c < cols; ++c) {
    const double az = 2.0 * kPi * static_cast<double>(c) / static_cast<double>(cols);
    s.cos_az.push_back(std::cos(az));
    s.sin_az.push_back(std::sin(az));
    const double t = fx.motion_skew ? column_time_offset(c, cols, period) : 0.0;
    s.time.push_back(static_cast<float>(t));
    if (fx.motion_skew || c == 0) {
      const Eigen::Isometry3d T = pose_at(t);
      s.R.push_back(T.linear());
      s.o.push_back(T.translation());
    }
  }
  s.enabled = enabled_for_visit(town, visit, fx.vegetation);
  return s;
}

/// One world ray (hash h): the nearest surface, the model's dropouts, the effects' dropouts, range noise. Leaves
/// *range NaN when nothing returns.
void cast_world_ray(const Town& town, const LidarModel& model, const SensorEffects& fx, const std::vector<std::uint8_t>& enabled, const Ray& wr,
                    std::uint64_t h, float* range, float* inten) {
  const auto& s_enabled = enabled;
  const Hit hit =
      fx.vegetation ? trace_foliage(town, s_enabled, wr, model.max_range, fx.foliage_density, h) : trace(town, s_enabled, wr, model.max_range);
  if (hit.prim == kNone || hit.t < model.min_range) return;
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  double refl = 0.0;
  bool glass = false;
  surface(town, wr, hit, &n, &refl, &glass);
  const double cos_inc = std::abs(n.dot(wr.d));
  const double intensity = std::clamp(refl * (0.3 + 0.7 * cos_inc), 0.0, 1.0);
  // Dropouts: the model's rate plus weak returns (far and dark or grazing surfaces) that the receiver misses.
  const double rel = hit.t / model.max_range;
  const double p_drop = glass ? 0.7 : model.dropout_rate + 1.5 * rel * rel * (1.0 - intensity);
  if (detail::hash_uniform(h) < p_drop) return;
  if (fx.dropouts && detail::hash_uniform(detail::mix64(h ^ kDropoutStream)) < effect_dropout(fx, rel, cos_inc, refl)) return;
  // Range noise: approximately Gaussian (Irwin-Hall sum of four 16-bit uniforms from one hash; unit variance).
  const std::uint64_t g = detail::mix64(h + 1);
  const double sum4 = static_cast<double>((g & 0xFFFF) + ((g >> 16) & 0xFFFF) + ((g >> 32) & 0xFFFF) + (g >> 48)) / 65536.0;
  const double noise = model.range_noise_sigma * (sum4 - 2.0) * 1.7320508075688772;
  *range = static_cast<float>(std::max(model.min_range, hit.t + noise));
  *inten = static_cast<float>(intensity);
}

/// Ray (ring r, column c) of the sweep.
void cast_sweep_ray(const Town& town, const LidarModel& model, const SensorEffects& fx, const Sweep& s, int c, int r, std::uint64_t seed,
                    float* range, float* inten) {
  const auto cu = static_cast<std::size_t>(c), ru = static_cast<std::size_t>(r);
  const std::size_t ray = cu * static_cast<std::size_t>(model.num_rings) + ru;
  const Eigen::Vector3d ds(s.cos_el[ru] * s.cos_az[cu], s.cos_el[ru] * s.sin_az[cu], s.sin_el[ru]);
  const std::size_t pc = s.R.size() == 1 ? 0 : cu;
  cast_world_ray(town, model, fx, s.enabled, make_ray(s.o[pc], s.R[pc] * ds), detail::hash_combine(seed, ray), range, inten);
}

/// One scan of a non-repetitive pattern (scan_pattern.hpp): every ray cast from the sensor pose at its time (poses at
/// 256 instants of the sweep with motion skew), returns in firing order, no ring indices.
PointCloud simulate_pattern(const Town& town, const LidarModel& model, const SensorPoseAt& pose_at, double period, const SensorEffects& fx,
                            std::uint64_t seed, int num_threads, int visit) {
  constexpr int kPoseBins = 256;
  const std::vector<PatternRay> rays = pattern_rays(model, period, seed);
  const std::vector<std::uint8_t> enabled = enabled_for_visit(town, visit, fx.vegetation);
  std::vector<Eigen::Isometry3d> poses;
  for (int b = 0; b < (fx.motion_skew ? kPoseBins : 1); ++b)
    poses.push_back(pose_at(fx.motion_skew ? -period * (kPoseBins - 1 - b) / kPoseBins : 0.0));
  const auto bin_of = [&](float t) {
    if (poses.size() == 1) return std::size_t{0};
    return static_cast<std::size_t>(std::clamp(static_cast<int>(std::lround((kPoseBins - 1) + t / period * kPoseBins)), 0, kPoseBins - 1));
  };
  std::vector<float> range(rays.size(), std::numeric_limits<float>::quiet_NaN()), inten(rays.size(), 0.0f);
  const int nt = num_threads > 0 ? num_threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 256) num_threads(nt)
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const Eigen::Isometry3d& T = poses[bin_of(rays[i].time)];
    cast_world_ray(town, model, fx, enabled, make_ray(T.translation(), T.linear() * rays[i].direction), detail::hash_combine(seed, i), &range[i],
                   &inten[i]);
  }
  PointCloud cloud;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    if (std::isnan(range[i])) continue;
    cloud.points.push_back((rays[i].direction * range[i]).cast<float>());
    cloud.intensity.push_back(inten[i]);
    if (fx.point_times) cloud.time.push_back(fx.motion_skew ? rays[i].time : 0.f);
  }
  return cloud;
}

/// The returns in ray order (thread-count independent): range times the beam direction in the sensor frame.
PointCloud compact(const LidarModel& model, const Sweep& s, const std::vector<float>& range, const std::vector<float>& inten, bool times) {
  PointCloud cloud;
  cloud.num_rings = model.num_rings;
  std::size_t count = 0;
  for (float v : range) count += std::isnan(v) ? 0u : 1u;
  cloud.points.resize(count);
  cloud.intensity.resize(count);
  cloud.ring.resize(count);
  if (times) cloud.time.resize(count);
  std::size_t k = 0;
  for (int c = 0; c < model.azimuth_steps; ++c) {
    const auto cu = static_cast<std::size_t>(c);
    for (int r = 0; r < model.num_rings; ++r) {
      const auto ru = static_cast<std::size_t>(r);
      const std::size_t ray = cu * static_cast<std::size_t>(model.num_rings) + ru;
      if (std::isnan(range[ray])) continue;
      const double t = range[ray];
      const double ce = s.cos_el[ru];
      cloud.points[k] =
          Eigen::Vector3f(static_cast<float>(t * ce * s.cos_az[cu]), static_cast<float>(t * ce * s.sin_az[cu]), static_cast<float>(t * s.sin_el[ru]));
      cloud.intensity[k] = inten[ray];
      cloud.ring[k] = static_cast<std::uint16_t>(r);
      if (times) cloud.time[k] = s.time[cu];
      ++k;
    }
  }
  return cloud;
}

}  // namespace

SensorEffects SensorEffects::none() {
  SensorEffects fx;
  fx.motion_skew = fx.point_times = fx.dropouts = fx.vegetation = false;
  return fx;
}

std::optional<std::string> SensorEffects::validate() const {
  if (!(dropout_rate >= 0.0 && dropout_rate < 1.0)) return std::string("dropout_rate must be in [0, 1)");
  if (!(dropout_range_gain >= 0.0) || !(dropout_grazing_gain >= 0.0) || !(dropout_dark_gain >= 0.0)) return std::string("dropout gains must be >= 0");
  if (!(foliage_density > 0.0 && foliage_density <= 100.0)) return std::string("foliage_density must be in (0, 100] per metre");
  return std::nullopt;
}

double column_time_offset(int column, int columns, double period) {
  if (columns <= 0) return 0.0;
  const int first = columns / 2;                                   // the column behind the sensor
  const int k = ((first - column) % columns + columns) % columns;  // firing order: clockwise from behind
  return -static_cast<double>(columns - 1 - k) * period / static_cast<double>(columns);
}

double cast_ray(const Town& town, const Eigen::Vector3d& origin, const Eigen::Vector3d& unit_direction, double max_range, int visit) {
  const auto enabled = enabled_for_visit(town, visit, false);
  const Hit h = trace(town, enabled, make_ray(origin, unit_direction.normalized()), max_range);
  return h.prim == kNone ? kInf : h.t;
}

PointCloud simulate_sweep(const Town& town, const LidarModel& model, const SensorPoseAt& pose_at, double period, const SensorEffects& effects,
                          std::uint64_t seed, int num_threads, int visit) {
  if (model.validate() || effects.validate() || (effects.motion_skew && !(period > 0.0))) {
    PointCloud empty;
    empty.num_rings = model.num_rings;
    return empty;
  }
  if (model.pattern != LidarModel::ScanPattern::kSpinning) return simulate_pattern(town, model, pose_at, period, effects, seed, num_threads, visit);
  const Sweep s = make_sweep(town, model, pose_at, period, effects, visit);
  const int cols = model.azimuth_steps;
  const std::size_t num_rays = static_cast<std::size_t>(model.num_rings) * static_cast<std::size_t>(cols);
  // Per-ray output: range (NaN = no return) and intensity; compacted afterwards in ray order.
  std::vector<float> range(num_rays, std::numeric_limits<float>::quiet_NaN());
  std::vector<float> inten(num_rays, 0.0f);
  const int nt = num_threads > 0 ? num_threads : omp_get_max_threads();

#pragma omp parallel for schedule(dynamic, 8) num_threads(nt)
  for (int c = 0; c < cols; ++c) {
    for (int r = 0; r < model.num_rings; ++r) {
      const std::size_t ray = static_cast<std::size_t>(c) * static_cast<std::size_t>(model.num_rings) + static_cast<std::size_t>(r);
      cast_sweep_ray(town, model, effects, s, c, r, seed, &range[ray], &inten[ray]);
    }
  }
  return compact(model, s, range, inten, effects.point_times);
}

PointCloud simulate_scan(const Town& town, const LidarModel& model, const Eigen::Isometry3d& T_world_sensor, std::uint64_t seed, int num_threads,
                         int visit) {
  return simulate_sweep(
      town, model, [&T_world_sensor](double) { return T_world_sensor; }, 0.0, SensorEffects::none(), seed, num_threads, visit);
}

}  // namespace loopd
