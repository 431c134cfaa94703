// The reflectance models: reciprocity, non-negativity, energy (directional albedo <= 1),
// the Cook-Torrance formula of models.md, the car-paint and pearlescent specifics, and
// a MERL table made from a Cook-Torrance paint.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <cmath>
#include <numbers>
#include <random>

#include "albedo.h"
#include "paintlab/brdf/carpaint.h"
#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/fresnel.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/brdf/pearlescent.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::brdf;
using test_support::directional_albedo;

namespace {

Vec3 random_upper(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  const double z = 0.02 + 0.98 * u(rng), phi = 2 * std::numbers::pi * u(rng);
  const double s = std::sqrt(1 - z * z);
  return {s * std::cos(phi), s * std::sin(phi), z};
}

Vec3 from_angles(double theta_deg, double phi_deg = 0) {
  const double t = theta_deg * std::numbers::pi / 180, p = phi_deg * std::numbers::pi / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

PaintSpec shipped(const std::string& name) { return load_paint_file(test::source_dir() / "paints" / (name + ".toml")); }

// An AxF-like car paint with a colour table that really varies (blue shifting to violet).
AxfCarPaintParams example_axf() {
  AxfCarPaintParams p;
  p.ior = 1.5;
  p.diffuse = 0.08;
  p.lobes = {{0.06, 0.35, 0.8}, {0.04, 0.15, 0.5}, {0.02, 0.05, 0.3}};
  p.chi.theta_h_samples = 3;
  p.chi.theta_i_samples = 4;
  p.chi.rgb.clear();
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 4; ++b) p.chi.rgb.push_back(Rgb(0.4 + 0.1 * b, 0.5 - 0.05 * a, 0.9 - 0.05 * b));
  return p;
}

std::vector<double> roughness_for_sampling(const PaintSpec& s) {
  std::vector<double> ms;
  if (auto p = s.cook_torrance())
    for (auto& l : p->lobes) ms.push_back(l.m);
  if (auto p = s.axf_carpaint())
    for (auto& l : p->lobes) {
      ms.push_back(l.spread);
      ms.push_back(l.spread * p->ior);  // refraction widens a lobe by about eta outside
    }
  if (auto p = s.pearlescent()) ms = {p->gloss_roughness, p->flake_roughness, p->flake_roughness * p->ior};
  return ms;
}

struct NamedBrdf {
  std::string name;
  std::shared_ptr<Brdf> brdf;
};

std::vector<NamedBrdf> every_model() {
  std::vector<NamedBrdf> v;
  for (const char* n : {"silver-metallic", "solid-blue", "pearlescent"}) v.push_back({n, make_brdf(shipped(n))});
  v.push_back({"axf", std::make_shared<AxfCarPaint>(example_axf())});
  v.push_back({"lambertian", std::make_shared<Lambertian>(Rgb(0.2, 0.5, 0.8))});
  // A tabulated Cook-Torrance paint stands for measured MERL data.
  const CookTorrance ct(Rgb(0.05, 0.1, 0.2), {{Rgb(0.05, 0.05, 0.06), 0.3, 0.5}});
  v.push_back({"merl", std::make_shared<MerlBrdf>(std::make_shared<const MerlTable>(tabulate(ct)))});
  return v;
}
}  // namespace

TEST(Models, ReciprocalAndNonNegative) {
  std::mt19937_64 rng(test::seed());
  for (const auto& m : every_model()) {
    double worst = 0;
    for (int n = 0; n < 20000; ++n) {
      const Vec3 wi = random_upper(rng), wo = random_upper(rng);
      const Rgb a = m.brdf->eval(wi, wo), b = m.brdf->eval(wo, wi);
      ASSERT_TRUE((a >= 0).all() && a.allFinite()) << m.name << " " << a.transpose();
      worst = std::max(worst, ((a - b).abs() / (a.abs() + 1e-12)).maxCoeff());
    }
    // Analytic models: rounding only. MERL: phi_d of the swapped pair is phi_d +- pi,
    // the same table point up to rounding.
    EXPECT_LT(worst, 1e-9) << m.name;
  }
}

TEST(Models, ZeroBelowTheHorizon) {
  for (const auto& m : every_model()) {
    EXPECT_TRUE((m.brdf->eval(from_angles(30), Vec3(0.3, 0, -0.95).normalized()) == 0).all()) << m.name;
    EXPECT_TRUE((m.brdf->eval(Vec3(0.3, 0, -0.95).normalized(), from_angles(30)) == 0).all()) << m.name;
  }
}

// Energy: for the shipped (plausible) paints the directional albedo stays <= 1 at every
// incidence up to 89 deg. Estimator: 200k multiple-importance samples per angle with a
// fixed seed; the standard error is checked to be below 0.004, and the assertion is
// albedo <= 1 + 3 standard errors (so the tolerance is at most 0.012).
TEST(Models, DirectionalAlbedoAtMostOne) {
  std::vector<std::pair<std::string, PaintSpec>> paints;
  for (const char* n : {"silver-metallic", "solid-blue", "pearlescent"}) paints.emplace_back(n, shipped(n));
  PaintSpec axf;
  axf.name = "axf";
  axf.params = example_axf();
  paints.emplace_back("axf", axf);
  for (const auto& [name, spec] : paints) {
    const auto brdf = make_brdf(spec);
    const auto ms = roughness_for_sampling(spec);
    for (double t : {0.0, 30.0, 60.0, 80.0, 89.0}) {
      const auto e = directional_albedo(*brdf, from_angles(t, 20), ms, 200000, test::seed());
      EXPECT_LT(e.std_error.maxCoeff(), 0.004) << name << " at " << t;
      for (int c = 0; c < 3; ++c) {
        EXPECT_LE(e.mean[c], 1.0 + 3 * e.std_error[c]) << name << " at " << t << " deg, channel " << c;
        // A sanity floor (at grazing incidence the clear coat's mirror takes nearly all).
        if (t <= 60) {
          EXPECT_GT(e.mean[c], 0.02) << name;
        }
      }
    }
  }
}

TEST(Models, AlbedoEstimatorIsExactForLambertAndSeesImplausiblePaints) {
  const Lambertian white(Rgb(0.9, 0.5, 0.1));
  const auto e = directional_albedo(white, from_angles(40), {0.1}, 100000, test::seed());
  EXPECT_THAT(e.mean, test::RgbNear(Rgb(0.9, 0.5, 0.1), 3 * e.std_error.maxCoeff() + 1e-9));
  // A lobe that reflects 4 ks F = 4 * 0.4 * ~1 of the light must fail the energy check.
  const CookTorrance bad(Rgb(0.2, 0.2, 0.2), {{Rgb::Constant(0.4), 0.2, 0.9}});
  const auto b = directional_albedo(bad, from_angles(30), {0.2}, 100000, test::seed());
  EXPECT_GT(b.mean[0], 1.0 + 10 * b.std_error[0]);
}

namespace {
// models.md eq. 1, written out independently of the library.
Rgb ct_reference(const Rgb& kd, const std::vector<CtLobe>& lobes, const Vec3& wi, const Vec3& wo) {
  const Vec3 h = (wi + wo).normalized();
  const double nh = h.z(), hv = h.dot(wo), th = std::acos(nh);
  Rgb f = kd / std::numbers::pi;
  for (const auto& l : lobes) {
    const double d = std::exp(-std::pow(std::tan(th), 2) / (l.m * l.m)) / (l.m * l.m * std::pow(std::cos(th), 4));
    const double fr = l.r + (1 - l.r) * std::pow(1 - hv, 5);
    const double g = std::min({1.0, 2 * nh * wo.z() / hv, 2 * nh * wi.z() / hv});
    f += l.ks * fr * d * g / (std::numbers::pi * wi.z() * wo.z());
  }
  return f;
}
}  // namespace

TEST(CookTorrance, MatchesModelsMdEquationOne) {
  const auto spec = shipped("silver-metallic");
  const auto& p = *spec.cook_torrance();
  const CookTorrance ct(p.kd, p.lobes);
  std::mt19937_64 rng(test::seed());
  for (int n = 0; n < 5000; ++n) {
    const Vec3 wi = random_upper(rng), wo = random_upper(rng);
    const Rgb ref = ct_reference(p.kd, p.lobes, wi, wo);
    ASSERT_LT(((ct.eval(wi, wo) - ref).abs() / ref).maxCoeff(), 1e-10);
    // The same value from the half/difference angles (what fits evaluate at bin means).
    const HalfDiff hd = half_diff_from_directions(wi, wo);
    ASSERT_LT(((ct.eval_half_diff(hd.theta_h, hd.theta_d, hd.phi_d) - ref).abs() / ref).maxCoeff(), 1e-8);
    // Diffuse plus lobes is the whole.
    Rgb sum = ct.eval_diffuse(wi, wo);
    for (std::size_t l = 0; l < p.lobes.size(); ++l) sum += ct.eval_lobe(l, wi, wo);
    ASSERT_LT(((sum - ref).abs() / ref).maxCoeff(), 1e-10);
  }
  // A hand-checked value: normal incidence and view, theta_h = 0: D = 1/m^2, F = r, G = 1.
  const CookTorrance one(Rgb::Zero(), {{Rgb::Ones(), 0.5, 0.25}});
  EXPECT_NEAR(one.eval(Vec3::UnitZ(), Vec3::UnitZ())[0], 0.25 * 4.0 / std::numbers::pi, 1e-12);
}

TEST(CookTorrance, LobeTemplateWorksWithCeresJets) {
  using J = ceres::Jet<double, 2>;
  const HalfDiff hd{0.08, 0.0, 0.6, 1.1};
  const J m(0.12, 0), r(0.3, 1);
  const J v = ct_lobe_half_diff(m, r, J(hd.theta_h), J(hd.theta_d), J(hd.phi_d));
  const double f0 = ct_lobe_half_diff(0.12, 0.3, hd.theta_h, hd.theta_d, hd.phi_d);
  EXPECT_NEAR(v.a, f0, 1e-12 * f0);
  const double eps = 1e-6;
  const double dm = (ct_lobe_half_diff(0.12 + eps, 0.3, hd.theta_h, hd.theta_d, hd.phi_d) -
                     ct_lobe_half_diff(0.12 - eps, 0.3, hd.theta_h, hd.theta_d, hd.phi_d)) / (2 * eps);
  const double dr = (ct_lobe_half_diff(0.12, 0.3 + eps, hd.theta_h, hd.theta_d, hd.phi_d) -
                     ct_lobe_half_diff(0.12, 0.3 - eps, hd.theta_h, hd.theta_d, hd.phi_d)) / (2 * eps);
  EXPECT_NEAR(v.v[0], dm, 1e-6 * std::abs(dm));
  EXPECT_NEAR(v.v[1], dr, 1e-6 * std::abs(dr));
  // With precomputed geometry.
  const LobeGeometry g = LobeGeometry::from_half_diff(hd.theta_h, hd.theta_d, hd.phi_d);
  EXPECT_NEAR(ct_lobe(m, r, g).a, f0, 1e-12 * f0);
  EXPECT_FALSE(LobeGeometry::from_half_diff(1.2, 1.2, 0.0).valid);  // wi below the horizon
  EXPECT_EQ(ct_lobe_half_diff(0.1, 0.5, 1.2, 1.2, 0.0), 0.0);
}

TEST(CarPaint, WithoutRefractionAndColourItIsCookTorrance) {
  AxfCarPaintParams p = example_axf();
  p.ior = 1.0;  // no clear coat: no refraction, no Fresnel loss
  p.chi = ColourTable{};
  const AxfCarPaint axf(p);
  std::vector<CtLobe> lobes;
  for (const auto& l : p.lobes) lobes.push_back({Rgb::Constant(l.coefficient), l.spread, l.f0});
  const CookTorrance ct(Rgb::Constant(p.diffuse), lobes);
  std::mt19937_64 rng(test::seed());
  for (int n = 0; n < 2000; ++n) {
    const Vec3 wi = random_upper(rng), wo = random_upper(rng);
    ASSERT_LT(((axf.eval(wi, wo) - ct.eval(wi, wo)).abs() / ct.eval(wi, wo)).maxCoeff(), 1e-9);
  }
}

TEST(CarPaint, ClearCoatRefractsAndTransmits) {
  const AxfCarPaintParams p = example_axf();
  const AxfCarPaint axf(p);
  const Vec3 wi = from_angles(50, 0), wo = from_angles(20, 180);
  const Vec3 ib = refract_into_coat(wi, 1.5), ob = refract_into_coat(wo, 1.5);
  EXPECT_NEAR(std::sin(std::acos(ib.z())), std::sin(50 * std::numbers::pi / 180) / 1.5, 1e-12);  // Snell
  const Vec3 hb = (ib + ob).normalized();
  const Rgb chi = p.chi.eval(std::acos(hb.z()), std::acos(hb.dot(ib)));
  const double t = (1 - fresnel_dielectric(wi.z(), 1.5)) * (1 - fresnel_dielectric(wo.z(), 1.5));
  EXPECT_THAT(axf.eval(wi, wo), test::RgbNear(chi * t * axf.achromatic_refracted(ib, ob), 1e-12));
  EXPECT_NEAR(fresnel_dielectric(1.0, 1.5), 0.04, 1e-12);
  EXPECT_NEAR(axf.clearcoat_reflectance(1.0), 0.04, 1e-12);
  EXPECT_NEAR(fresnel_dielectric(0.0, 1.5), 1.0, 1e-12);
}

TEST(CarPaint, ColourTableSamplingHasHalfTexelOffsets) {
  const ColourTable chi = example_axf().chi;  // 3 theta_h x 4 theta_i
  const double hp = std::numbers::pi / 2;
  // Sample (a, b) sits at theta_h = (a + 0.5) / 3 * pi/2, theta_i = (b + 0.5) / 4 * pi/2.
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 4; ++b)
      EXPECT_THAT(chi.eval((a + 0.5) / 3 * hp, (b + 0.5) / 4 * hp), test::RgbNear(chi.rgb[a * 4 + b], 1e-12));
  // Halfway between two samples: their mean; beyond the outer samples: clamped.
  EXPECT_THAT(chi.eval(1.0 / 3 * hp, 0.5 / 4 * hp), test::RgbNear(0.5 * (chi.rgb[0] + chi.rgb[4]), 1e-12));
  EXPECT_THAT(chi.eval(0.0, 0.0), test::RgbNear(chi.rgb[0], 1e-12));
  EXPECT_THAT(chi.eval(hp, hp), test::RgbNear(chi.rgb[11], 1e-12));
  ColourTable scaled = chi;
  scaled.scale = 2.0;
  EXPECT_THAT(scaled.eval(0.3, 0.4), test::RgbNear(2.0 * chi.eval(0.3, 0.4), 1e-12));
}

TEST(Pearlescent, FlakeColourShiftsWithAngle) {
  const auto spec = shipped("pearlescent");
  const LayeredPearlescent pearl(*spec.pearlescent());
  // Chromaticity b / g of the flake reflectance: different near and far from retro.
  const Rgb near = pearl.flake_reflectance(5 * std::numbers::pi / 180), far = pearl.flake_reflectance(60 * std::numbers::pi / 180);
  EXPECT_GT(std::abs(far[2] / far[1] - near[2] / near[1]), 0.5);
  // And so the glitter term of the BRDF changes colour between geometries.
  const Rgb g1 = pearl.eval_glitter(from_angles(10, 0), from_angles(10, 180));
  const Rgb g2 = pearl.eval_glitter(from_angles(70, 0), from_angles(70, 180));
  EXPECT_GT(std::abs(g2[2] / g2[1] - g1[2] / g1[1]), 0.2);
  // The table eval() uses agrees with Airy's formula.
  for (double a = 0; a < 1.57; a += 0.05)
    EXPECT_THAT(pearl.flake_reflectance_fast(std::cos(a)), test::RgbNear(pearl.flake_reflectance(a), 1e-4));
}

TEST(Pearlescent, TermsAddUpAndGlossIsTheFresnelOfTheBoundary) {
  const auto spec = shipped("pearlescent");
  const LayeredPearlescent pearl(*spec.pearlescent());
  std::mt19937_64 rng(test::seed());
  for (int n = 0; n < 1000; ++n) {
    const Vec3 wi = random_upper(rng), wo = random_upper(rng);
    const Rgb sum = pearl.eval_gloss(wi, wo) + pearl.eval_glitter(wi, wo) + pearl.eval_shade(wi, wo);
    ASSERT_LT(((pearl.eval(wi, wo) - sum).abs()).maxCoeff(), 1e-12 * sum.maxCoeff());
  }
  // The gloss alone reflects about F(0) = 0.04 at normal incidence (its microfacet G
  // loses a little): within 10 %.
  struct GlossOnly : Brdf {
    const LayeredPearlescent* p;
    Rgb eval(const Vec3& wi, const Vec3& wo) const override { return p->eval_gloss(wi, wo); }
    std::string model() const override { return "gloss"; }
  } gloss;
  gloss.p = &pearl;
  const auto e = directional_albedo(gloss, from_angles(0), {spec.pearlescent()->gloss_roughness}, 100000, test::seed());
  EXPECT_NEAR(e.mean[0], 0.04, 0.004);
}

// A MERL table tabulated from a Cook-Torrance paint reproduces the paint within the
// error of binning: exactly at bin centres, and by trilinear interpolation in between.
TEST(MerlFromPaint, AgreesWithThePaintWithinBinningError) {
  const CookTorrance ct(Rgb(0.05, 0.1, 0.3), {{Rgb(0.06, 0.06, 0.07), 0.35, 0.6}, {Rgb(0.05, 0.05, 0.05), 0.12, 0.1}});
  const auto table = std::make_shared<const MerlTable>(tabulate(ct));
  const MerlBrdf merl(table);
  // Bin centres: the lookup returns the tabulated value itself.
  std::mt19937_64 rng(test::seed());
  std::uniform_int_distribution<int> bi(0, 89), bk(0, 179);
  for (int n = 0; n < 2000; ++n) {
    const int i = bi(rng) / 2, j = bi(rng) / 2, k = bk(rng);  // keep above the horizon
    const HalfDiff hd{merl_theta_h_centre(i), 0.7, merl_theta_d_centre(j), merl_phi_d_centre(k)};
    const DirectionPair d = directions_from_half_diff(hd);
    ASSERT_LT(((merl.eval(d.wi, d.wo) - ct.eval(d.wi, d.wo)).abs() / ct.eval(d.wi, d.wo)).maxCoeff(), 1e-9);
  }
  // Anywhere with both directions within 70 deg of the normal.
  std::vector<double> rel;
  for (int n = 0; n < 20000; ++n) {
    const Vec3 wi = random_upper(rng), wo = random_upper(rng);
    if (wi.z() < std::cos(70 * std::numbers::pi / 180) || wo.z() < std::cos(70 * std::numbers::pi / 180)) continue;
    const Rgb f = ct.eval(wi, wo);
    rel.push_back(((merl.eval(wi, wo) - f).abs() / f).maxCoeff());
  }
  std::sort(rel.begin(), rel.end());
  const double median = rel[rel.size() / 2], p99 = rel[rel.size() * 99 / 100];
  std::printf("MERL vs Cook-Torrance over %zu directions: median %.3g %%, 99th percentile %.3g %%, max %.3g %%\n",
              rel.size(), 100 * median, 100 * p99, 100 * rel.back());
  // Measured: median 0.03 %, 99th percentile 0.3 %, max 0.9 %.
  EXPECT_LT(median, 0.001);
  EXPECT_LT(p99, 0.006);
  EXPECT_LT(rel.back(), 0.02);
}

TEST(CarPaint, CoatGeometryWorksWithCeresJets) {
  using J = ceres::Jet<double, 1>;
  const Vec3 wi = from_angles(55, 10), wo = from_angles(25, 200);
  const auto g = coat_geometry(J(1.5, 0), wi, wo);
  const auto g0 = coat_geometry(1.5, wi, wo);
  EXPECT_NEAR(g.transmittance.a, g0.transmittance, 1e-15);
  const double eps = 1e-6;
  const double d = (coat_geometry(1.5 + eps, wi, wo).transmittance - coat_geometry(1.5 - eps, wi, wo).transmittance) /
                   (2 * eps);
  EXPECT_NEAR(g.transmittance.v[0], d, 1e-6 * std::abs(d));
  // The cosines match the refracted directions.
  const Vec3 ib = refract_into_coat(wi, 1.5), ob = refract_into_coat(wo, 1.5), hb = (ib + ob).normalized();
  EXPECT_NEAR(g0.n_dot_hbar, hb.z(), 1e-12);
  EXPECT_NEAR(g0.hbar_dot_obar, hb.dot(ob), 1e-12);
  EXPECT_NEAR(g0.hbar_dot_obar, hb.dot(ib), 1e-12);
  EXPECT_NEAR(g0.n_dot_ibar, ib.z(), 1e-12);
}

TEST(MerlFromPaint, DegenerateAnglesAreSafe) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(merl_bin({nan, nan, nan, nan}), (MerlBin{0, 0, 0}));
  EXPECT_EQ(merl_bin({1e300, 0, 1e300, 1e300}), (MerlBin{89, 89, 179}));
  MerlTable t;
  t.set_value(0, Rgb::Ones(), BinState::Measured);
  EXPECT_FALSE(t.lookup({nan, 0, 0.1, 0.1}).has_value());
}
