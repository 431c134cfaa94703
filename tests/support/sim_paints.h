#pragma once
// Simulated paints that several tests share (header only: the tests that include it link
// paintlab_sim themselves).
#include <memory>
#include <vector>

#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/sim/paint.h"

namespace paintlab::test {

// A glossy black calibration sphere: little diffuse (0.01), one Beckmann lobe of m = 0.03,
// ks 0.6, Fresnel r 0.05.
inline sim::SimPaint glossy_black_sphere() {
  brdf::CtLobe lobe;
  lobe.ks = brdf::Rgb(0.6, 0.6, 0.6);
  lobe.m = 0.03;
  lobe.r = 0.05;
  sim::SimPaint p;
  p.brdf = std::make_shared<brdf::CookTorrance>(brdf::Rgb(0.01, 0.01, 0.01), std::vector<brdf::CtLobe>{lobe});
  return p;
}

}  // namespace paintlab::test
