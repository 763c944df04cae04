#pragma once
/// @file Small surface-sampled scenes for GICP and verification tests (no ray casting; the simulator in src/loopd/sim
/// covers that). Deterministic for a seed.
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace loopd::test {

/// Samples `n` points uniformly on the axis-aligned rectangle spanned by `origin`, `origin + a`, `origin + b`.
inline void sample_rect(std::vector<Eigen::Vector3f>* out, const Eigen::Vector3f& origin, const Eigen::Vector3f& a, const Eigen::Vector3f& b, int n,
                        std::mt19937* rng, float noise) {
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::normal_distribution<float> g(0.f, 1.f);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3f p = origin + u(*rng) * a + u(*rng) * b;
    if (noise > 0.f) p += noise * Eigen::Vector3f(g(*rng), g(*rng), g(*rng));
    out->push_back(p);
  }
}

/// Samples a vertical cylinder (pole / tree trunk) of radius r and height h standing at (x, y).
inline void sample_pole(std::vector<Eigen::Vector3f>* out, float x, float y, float r, float h, int n, std::mt19937* rng, float noise) {
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::normal_distribution<float> g(0.f, 1.f);
  for (int i = 0; i < n; ++i) {
    const float a = 6.2831853f * u(*rng);
    Eigen::Vector3f p(x + r * std::cos(a), y + r * std::sin(a), h * u(*rng));
    if (noise > 0.f) p += noise * Eigen::Vector3f(g(*rng), g(*rng), g(*rng));
    out->push_back(p);
  }
}

/// Samples a closed box (car, kiosk) with its lower corner at c and size s.
inline void sample_box(std::vector<Eigen::Vector3f>* out, const Eigen::Vector3f& c, const Eigen::Vector3f& s, int n_per_face, std::mt19937* rng,
                       float noise) {
  const Eigen::Vector3f X(s.x(), 0, 0), Y(0, s.y(), 0), Z(0, 0, s.z());
  sample_rect(out, c, X, Z, n_per_face, rng, noise);
  sample_rect(out, c + Y, X, Z, n_per_face, rng, noise);
  sample_rect(out, c, Y, Z, n_per_face, rng, noise);
  sample_rect(out, c + X, Y, Z, n_per_face, rng, noise);
  sample_rect(out, c + Z, X, Y, n_per_face, rng, noise);
}

/// An asymmetric street corner around the origin: ground, facades on both sides with a side street, a few poles
/// and boxes. About 9000 points. `seed` only changes the sampling (same surfaces).
inline std::vector<Eigen::Vector3f> street_scene(std::uint32_t seed, float noise = 0.01f) {
  std::mt19937 rng(seed);
  std::vector<Eigen::Vector3f> pts;
  sample_rect(&pts, {-30, -12, 0}, {60, 0, 0}, {0, 24, 0}, 3000, &rng, noise);  // ground
  sample_rect(&pts, {-30, 8, 0}, {22, 0, 0}, {0, 0, 9}, 900, &rng, noise);      // left facade, part 1
  sample_rect(&pts, {-2, 9.5f, 0}, {28, 0, 0}, {0, 0, 14}, 1000, &rng, noise);  // left facade, part 2 (set back)
  sample_rect(&pts, {-8, 8, 0}, {0, 1.5f, 0}, {0, 0, 9}, 120, &rng, noise);     // step between the two
  sample_rect(&pts, {-30, -7, 0}, {14, 0, 0}, {0, 0, 7}, 700, &rng, noise);     // right facade before side street
  sample_rect(&pts, {-16, -7, 0}, {0, -5, 0}, {0, 0, 7}, 300, &rng, noise);     // side-street corner
  sample_rect(&pts, {-6, -7, 0}, {0, -5, 0}, {0, 0, 11}, 300, &rng, noise);     // other corner
  sample_rect(&pts, {-6, -7, 0}, {30, 0, 0}, {0, 0, 11}, 1000, &rng, noise);    // right facade after side street
  sample_pole(&pts, 3, 6, 0.2f, 6, 150, &rng, noise);
  sample_pole(&pts, 14, 6.5f, 0.25f, 7, 150, &rng, noise);
  sample_pole(&pts, -20, -5.5f, 0.2f, 5, 150, &rng, noise);
  sample_pole(&pts, 20, -5, 0.3f, 8, 150, &rng, noise);
  sample_box(&pts, {5, -5.5f, 0}, {4.2f, 1.8f, 1.5f}, 80, &rng, noise);
  sample_box(&pts, {-12, 5.5f, 0}, {4.5f, 1.9f, 1.6f}, 80, &rng, noise);
  sample_box(&pts, {22, 4, 0}, {2, 2, 2.5f}, 60, &rng, noise);
  return pts;
}

/// A straight tunnel along x (rectangular cross-section 8 m x 5 m, 60 m long) with no features: translation along x
/// is unobservable.
inline std::vector<Eigen::Vector3f> tunnel_scene(std::uint32_t seed, float noise = 0.01f) {
  std::mt19937 rng(seed);
  std::vector<Eigen::Vector3f> pts;
  sample_rect(&pts, {-30, -4, 0}, {60, 0, 0}, {0, 8, 0}, 2500, &rng, noise);  // floor
  sample_rect(&pts, {-30, -4, 5}, {60, 0, 0}, {0, 8, 0}, 2500, &rng, noise);  // ceiling
  sample_rect(&pts, {-30, -4, 0}, {60, 0, 0}, {0, 0, 5}, 2000, &rng, noise);  // wall
  sample_rect(&pts, {-30, 4, 0}, {60, 0, 0}, {0, 0, 5}, 2000, &rng, noise);   // wall
  return pts;
}

inline std::vector<Eigen::Vector3f> transformed(const std::vector<Eigen::Vector3f>& pts, const Eigen::Isometry3d& T) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(pts.size());
  const Eigen::Isometry3f Tf = T.cast<float>();
  for (const auto& p : pts) out.push_back(Tf * p);
  return out;
}

inline double rotation_error_deg(const Eigen::Isometry3d& A, const Eigen::Isometry3d& B) {
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(A.linear().transpose() * B.linear()));
  return std::abs(aa.angle()) * 180.0 / M_PI;
}
inline double translation_error(const Eigen::Isometry3d& A, const Eigen::Isometry3d& B) { return (A.translation() - B.translation()).norm(); }

}  // namespace loopd::test
