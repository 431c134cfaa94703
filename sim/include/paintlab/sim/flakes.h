#pragma once
// Sparkle (models.md "Sparkle"). Flakes are mirrors at fixed places on the sphere (a
// Poisson process in surface coordinates, seeded per surface cell, so the pattern is
// stable between frames) whose normals follow a Beckmann distribution of roughness m
// around the surface normal (theta = atan(m sqrt(-log(1 - r1))), phi = 2 pi r2; Günther
// 2005, 5.2). A flake glints when its normal lies within the lifetime angle delta of the
// half vector h.
//
// A pixel's specular part is scaled by s = (K + eps) / (lambda + eps): K = glinting flakes
// in the pixel's footprint, lambda = E[K] = N * P(theta_h), N = expected flakes in the
// footprint, P = the probability that one flake glints (FlakeCapTable). E[s] = 1 exactly
// for any eps > 0, so averaging many pixels recovers the paint's BRDF; eps (the sparkle
// floor) bounds the variance by 1 / (4 eps) and stands for the unresolved fine pigment.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "paintlab/core/geometry.h"

namespace paintlab::sim {

// P(angle(flake normal, h) < delta) as a function of the angle theta_h between h and the
// surface normal, for Beckmann(m) flake normals; tabulated over sin(theta_h / 2).
class FlakeCapTable {
 public:
  FlakeCapTable(double roughness, double lifetime_rad, int entries = 512);
  // cos_theta_h = n . h.
  double operator()(double cos_theta_h) const;
  // The exact integral (1D quadrature) at one angle; the table interpolates it.
  static double integrate(double roughness, double lifetime_rad, double theta_h);

 private:
  std::vector<double> values_;
  double step_;  // in sin(theta_h / 2)
};

// One flake: its place (unit vector from the sphere centre) and its normal, in the rig
// frame, and random bits for its colour (draw_flake_tint), from a stream of their own.
struct Flake {
  Vec3 position_dir;
  Vec3 normal;
  std::uint64_t colour_bits = 0;
};

// The flakes' own colour (brdf::FlakeSpec, docs/paint-files.md "Flake colour"). A flake's
// glint is the carried part of the BRDF times its tint t = 1 + c (cos(psi) u + sin(psi) v),
// u = (2, -1, -1) / sqrt 6 and v = (0, 1, -1) / sqrt 2 the unit vectors of the RGB plane
// orthogonal to grey. Ordinary flakes: (c cos psi, c sin psi) ~ N(0, tint_sd^2) per axis with
// c clipped at 1 (symmetric, so the mean tint stays grey); interference flakes (a fraction
// `interference`): c = interference_chroma and psi = psi_0 + shift * (angle between light and
// flake normal), psi_0 uniform. Either way E[t] = (1, 1, 1) at every angle: the sparkle
// averages to the BRDF whatever the colours, and t >= 1 - sqrt(2/3) > 0.
struct FlakeColour {
  double tint_sd = 0.0;
  double interference = 0.0;
  double interference_chroma = 0.5;
  double interference_shift_deg = 6.0;
  bool any() const { return tint_sd > 0 || interference > 0; }
};

struct FlakeTint {
  double chroma = 0.0;   // c, [0, 1]
  double hue_rad = 0.0;  // psi (interference flakes: psi_0)
  bool interference = false;
};
FlakeTint draw_flake_tint(std::uint64_t colour_bits, const FlakeColour& colour);
// t(c, psi) above.
Vec3 flake_tint_rgb(double chroma, double hue_rad);

// The flakes on a sphere of radius r: flakes_per_m2 on average. Cells are equal-area
// (z, phi) bins (Archimedes), each with a Poisson number of uniformly placed flakes.
class FlakeField {
 public:
  FlakeField(double radius_m, double flakes_per_m2, double roughness, std::uint64_t seed);
  double flakes_per_m2() const { return density_; }
  std::int64_t cell_count() const { return static_cast<std::int64_t>(nz_) * nphi_; }
  // Calls f(const Flake&) for every flake whose surface point is visible from a viewer at
  // `viewer_from_centre_m` (relative to the sphere centre), in cells for which
  // keep_cell(cell centre direction, cell angular radius in rad) is true.
  template <class F, class Keep>
  void for_each_visible(const Vec3& viewer_from_centre_m, F&& f, Keep&& keep_cell) const;
  template <class F>
  void for_each_visible(const Vec3& viewer_from_centre_m, F&& f) const {
    for_each_visible(viewer_from_centre_m, f, [](const Vec3&, double) { return true; });
  }
  // All flakes of one cell (for tests of the statistics).
  std::vector<Flake> cell(int iz, int iphi) const;

 private:
  double radius_, density_, roughness_;
  std::uint64_t seed_;
  int nz_, nphi_;
  double mean_per_cell_;
};

template <class F, class Keep>
void FlakeField::for_each_visible(const Vec3& viewer_from_centre_m, F&& f, Keep&& keep_cell) const {
  double d = viewer_from_centre_m.norm();
  Vec3 v = viewer_from_centre_m / d;
  double horizon = radius_ / d;  // a surface point u is visible when u . v > r / d
  const double dphi = 2.0 * kPi / nphi_;
  constexpr int kBlock = 64;  // cells tested together before testing them one by one
  for (int iz = 0; iz < nz_; ++iz) {
    double z_lo = -1.0 + 2.0 * iz / nz_, z_hi = -1.0 + 2.0 * (iz + 1) / nz_;
    // Skip whole rings that cannot face the viewer.
    double best = -1e9;
    for (double z : {z_lo, z_hi, std::clamp(v.z(), z_lo, z_hi)}) {
      double s = std::sqrt(std::max(0.0, 1.0 - z * z));
      best = std::max(best, z * v.z() + s * v.head<2>().norm());
    }
    if (best < horizon - 1e-9) continue;
    // A generous angular radius of a cell (and of a block) around (z_c, phi_c).
    double z_c = 0.5 * (z_lo + z_hi), s_c = std::sqrt(std::max(0.0, 1.0 - z_c * z_c));
    double dtheta = std::acos(z_lo) - std::acos(z_hi);
    double s_max = (z_lo <= 0 && z_hi >= 0) ? 1.0 : std::sqrt(std::max(0.0, 1.0 - std::min(z_lo * z_lo, z_hi * z_hi)));
    auto radius = [&](int cells) { return std::sqrt(dtheta * dtheta + 0.25 * std::pow(cells * dphi * s_max, 2)); };
    auto centre = [&](double phi) { return Vec3(s_c * std::cos(phi), s_c * std::sin(phi), z_c); };
    for (int b0 = 0; b0 < nphi_; b0 += kBlock) {
      int b1 = std::min(nphi_, b0 + kBlock);
      if (!keep_cell(centre(0.5 * (b0 + b1) * dphi), radius(b1 - b0))) continue;
      for (int ip = b0; ip < b1; ++ip) {
        if (!keep_cell(centre((ip + 0.5) * dphi), radius(1))) continue;
        for (const Flake& fl : cell(iz, ip))
          if (fl.position_dir.dot(v) > horizon) f(fl);
      }
    }
  }
}

}  // namespace paintlab::sim
