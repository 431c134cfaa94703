// The cosine-lobe basis (issue 17 item 2, docs/design.md "Cosine-lobe basis"): the solvers, a
// paint's weights, the exponents of a library and the design of a paint from multi-angle
// CIELAB targets.
#include "paintlab/fitting/cosine_lobes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <random>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/error.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::shared_ptr<const brdf::Brdf> paint(const char* file) {
  return brdf::make_brdf(brdf::load_paint_file(test::source_dir() / "paints" / file));
}

brdf::CosineLobeParams lobes(std::vector<double> e, brdf::Rgb kd, std::vector<brdf::Rgb> kg, std::vector<brdf::Rgb> kdd) {
  brdf::CosineLobeParams p;
  p.exponents = std::move(e);
  p.kd = kd;
  p.kg = std::move(kg);
  p.kdd = std::move(kdd);
  return p;
}

TEST(CosineLobes, ModelIsTheSourcesFormula) {
  const auto p = lobes({4, 300}, {0.2, 0.3, 0.4}, {{0.5, 0.5, 0.5}, {2.0, 2.0, 2.0}}, {{0.1, 0.2, 0.3}, {0, 0, 0}});
  const brdf::CosineLobes m(p);
  const double ti = 0.6, to = 0.5, phi = 2.9;  // near the mirror direction, out of plane
  const brdf::Vec3 wi(std::sin(ti), 0, std::cos(ti));
  const brdf::Vec3 wo(std::sin(to) * std::cos(phi), std::sin(to) * std::sin(phi), std::cos(to));
  const brdf::Vec3 r(-wi.x(), -wi.y(), wi.z());
  const double rv = r.dot(wo);
  for (int c = 0; c < 3; ++c) {
    const double radiance = p.kd[c] / std::numbers::pi * wi.z() + p.kg[0][c] * std::pow(rv, 4) + p.kg[1][c] * std::pow(rv, 300) +
                            wi.z() * (p.kdd[0][c] * std::pow(rv, 4) + p.kdd[1][c] * std::pow(rv, 300));
    EXPECT_NEAR(m.eval(wi, wo)[c] * wi.z(), radiance, 1e-12 * radiance);
  }
  // Beyond 90 deg from the mirror direction only the diffuse term is left.
  const brdf::Vec3 back(std::sin(1.4), 0, std::cos(1.4));
  EXPECT_NEAR(m.eval(wi, back)[0], 0.2 / std::numbers::pi, 1e-12);
}

TEST(CosineLobes, SolversFindKnownNonNegativeSolutions) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::MatrixXd A(40, 5);
  for (Eigen::Index i = 0; i < A.size(); ++i) A.data()[i] = u(rng);
  Eigen::VectorXd truth(5);
  truth << 0.5, 0.0, 2.0, 0.0, 1.25;
  const Eigen::VectorXd b = A * truth;
  EXPECT_LT((nnls(A, b) - truth).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((nonnegative_l1(A, b) - truth).cwiseAbs().maxCoeff(), 1e-7);
  // A right-hand side that wants a negative weight: the constrained optimum keeps it at 0, and
  // its objective is no worse than that of any non-negative point tried at random.
  Eigen::VectorXd want(5);
  want << 1.0, -0.8, 0.5, 0.3, 0.0;
  const Eigen::VectorXd c = A * want;
  const Eigen::VectorXd x2 = nnls(A, c), x1 = nonnegative_l1(A, c);
  EXPECT_GE(x2.minCoeff(), 0.0);
  EXPECT_GE(x1.minCoeff(), 0.0);
  const double l2 = (A * x2 - c).norm(), l1 = (A * x1 - c).lpNorm<1>();
  for (int trial = 0; trial < 2000; ++trial) {
    Eigen::VectorXd y = x2;
    for (Eigen::Index j = 0; j < 5; ++j) y[j] = std::max(0.0, y[j] + 0.05 * (u(rng) - 0.5));
    EXPECT_GE((A * y - c).norm(), l2 - 1e-12);
    Eigen::VectorXd z = x1;
    for (Eigen::Index j = 0; j < 5; ++j) z[j] = std::max(0.0, z[j] + 0.05 * (u(rng) - 0.5));
    EXPECT_GE((A * z - c).lpNorm<1>(), l1 - 1e-9);
  }
}

TEST(CosineLobes, FitRecoversACosineLobePaint) {
  const auto p = lobes({3, 40, 900}, {0.05, 0.1, 0.2}, {{0, 0, 0}, {0.3, 0.2, 0.1}, {5, 5, 5}},
                       {{0.2, 0.1, 0.05}, {0, 0, 0}, {0, 0, 0}});
  for (const LobeNorm norm : {LobeNorm::L1, LobeNorm::L2}) {
    const CosineLobeFit fit = fit_cosine_lobes(brdf::CosineLobes(p), p.exponents, norm);
    EXPECT_LT(fit.max_error, 1e-6);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(fit.params.kd[c], p.kd[c], 1e-6);
      for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_NEAR(fit.params.kg[i][c], p.kg[i][c], 1e-6 * (1 + p.kg[i][c]));
        EXPECT_NEAR(fit.params.kdd[i][c], p.kdd[i][c], 1e-6);
      }
    }
  }
  EXPECT_THROW(fit_cosine_lobes(brdf::CosineLobes(p), {40, 3}), UsageError);
  EXPECT_EQ(cosine_fit_geometries().size(), 758u);  // as docs/design.md states
}

// The library of the tests: three measured-paint shapes of paints/ (Cook-Torrance, one of
// them with a clear coat 10^5 times its diffuse level).
std::vector<std::pair<std::string, std::shared_ptr<const brdf::Brdf>>> library() {
  return {{"red-metallic", paint("red-metallic.toml")},
          {"silver-metallic", paint("silver-metallic.toml")},
          {"dark-metallic", paint("dark-metallic.toml")}};
}

TEST(CosineBasis, MoreLobesFitTheLibraryBetterAndTheTableRoundTrips) {
  CosineBasisOptions o;
  o.max_lobes = 5;
  o.max_evaluations = 200;
  std::vector<int> seen;
  o.progress = [&](const CosineBasisRow& r) { seen.push_back(r.lobes); };
  const CosineBasis b = fit_cosine_basis(library(), o);
  ASSERT_EQ(b.table.size(), 5u);
  EXPECT_EQ(seen, (std::vector<int>{1, 2, 3, 4, 5}));
  for (std::size_t i = 1; i < b.table.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_LE(b.table[i].criterion(), b.table[i - 1].criterion() * 1.02);
    EXPECT_TRUE(std::is_sorted(b.table[i].exponents.begin(), b.table[i].exponents.end()));
  }
  // One lobe cannot hold a flake lobe and a clear coat at once (measured: criterion 82 % with
  // one lobe, 41 % with five; mean relative error 41 % and 20 %: the rest is what cosine lobes
  // about the mirror direction cannot be, docs/design.md).
  EXPECT_GT(b.table[0].criterion(), 1.7 * b.table[4].criterion());
  EXPECT_LT(b.table[4].mean_error, 0.25);
  EXPECT_EQ(static_cast<int>(b.exponents.size()), b.lobes);
  EXPECT_LE(b.table[static_cast<std::size_t>(b.lobes - 1)].criterion(), 1.1 * b.table[4].criterion() + 1e-12);

  const test::TempDir tmp;
  const fs::path dir = tmp.path();
  write_cosine_basis(dir / "basis.json", b);
  const CosineBasis back = read_cosine_basis(dir / "basis.json");
  EXPECT_EQ(back.exponents, b.exponents);
  ASSERT_EQ(back.table.size(), b.table.size());
  EXPECT_EQ(back.table[2].exponents, b.table[2].exponents);
  EXPECT_EQ(back.paints, b.paints);
  EXPECT_THAT(cosine_basis_table(b), HasSubstr("<- kept"));

  // The basis reproduces the Cook-Torrance paints of the library within the error docs/design.md
  // states: at the five in-plane angles of the instruments dE00 at most 2.5 (measured worst
  // 0.43-1.44), 1 on average (measured 0.21-0.58); mean relative error 22 % (measured 17.5-18.8 %).
  for (const auto& [name, brdf] : library()) {
    SCOPED_TRACE(name);
    const CosineLobeFit fit = fit_cosine_lobes(*brdf, b.table[4].exponents);
    EXPECT_LT(fit.mean_error, 0.22);
    const auto truth = colour_at(*brdf, geometry_set("five-angle"));
    const auto lobes = colour_at(brdf::CosineLobes(fit.params), geometry_set("five-angle"));
    double sum = 0, worst = 0;
    for (std::size_t k = 0; k < truth.size(); ++k) {
      const double de = colour::delta_e_2000(truth[k].lab, lobes[k].lab);
      EXPECT_LT(de, 2.5) << truth[k].geometry.name;
      sum += de;
      worst = std::max(worst, de);
    }
    const Geometry behind = parse_geometry("45as-15");
    const double de_behind = colour::delta_e_2000(colour_at(*brdf, {behind})[0].lab,
                                                  colour_at(brdf::CosineLobes(fit.params), {behind})[0].lab);
    std::printf("%s: mean relative error %.3f, five-angle dE00 mean %.2f, worst %.2f; 45as-15 %.2f\n", name.c_str(),
                fit.mean_error, sum / static_cast<double>(truth.size()), worst, de_behind);
    EXPECT_LT(sum / static_cast<double>(truth.size()), 1.0);
  }
}

TEST(CosineBasis, BadInputIsRefused) {
  EXPECT_THROW(fit_cosine_basis({}), UsageError);
  CosineBasisOptions o;
  o.max_lobes = 12;
  EXPECT_THROW(fit_cosine_basis(library(), o), UsageError);
  const test::TempDir tmp;
  const fs::path dir = tmp.path();
  std::ofstream(dir / "b.json") << R"({"format": "paintlab-cosine-basis", "version": 1, "exponents": [50, 3]})";
  const std::string msg = test::error_message<DataError>([&] { read_cosine_basis(dir / "b.json"); });
  EXPECT_THAT(msg, HasSubstr("b.json"));
  EXPECT_THAT(msg, HasSubstr("exponents[1]"));
}

std::vector<DesignTarget> targets_of(const brdf::Brdf& b, const std::string& set) {
  std::vector<DesignTarget> t;
  for (const AngleColour& c : colour_at(b, geometry_set(set))) t.push_back({c.geometry, c.lab});
  return t;
}

const std::vector<double> kExponents = {2, 9, 40, 180, 800, 3600};

TEST(CosineDesign, ReachableTargetsAreHitWithinHalfADeltaE) {
  // The five-angle colour of Cook-Torrance paints (silver, blue: the basis can make them; red's
  // 45as75 it misses by 0.73) and of the red's own basis form (reachable by construction).
  const auto red = fit_cosine_lobes(*paint("red-metallic.toml"), kExponents);
  const std::vector<std::pair<std::string, std::shared_ptr<const brdf::Brdf>>> paints = {
      {"silver-metallic", paint("silver-metallic.toml")},
      {"solid-blue", paint("solid-blue.toml")},
      {"red-metallic as cosine lobes", std::make_shared<brdf::CosineLobes>(red.params)}};
  for (const auto& [name, brdf] : paints) {
    SCOPED_TRACE(name);
    const DesignResult r = design_paint(kExponents, targets_of(*brdf, "five-angle"));
    ASSERT_EQ(r.angles.size(), 5u);
    for (const auto& a : r.angles) {
      EXPECT_TRUE(a.reached) << a.target.geometry.name << " " << a.why;
      EXPECT_LE(a.de00, kDesignToleranceDe00);
    }
    EXPECT_TRUE(r.all_reached());
    EXPECT_TRUE(brdf::cosine_lobes_problem(r.params).empty());
    // The designed paint, evaluated on its own, has the colour the table reports.
    const auto again = colour_at(brdf::CosineLobes(r.params), geometry_set("five-angle"));
    for (std::size_t k = 0; k < 5; ++k) EXPECT_NEAR(again[k].lab.L, r.angles[k].achieved.L, 1e-9);
  }
}

TEST(CosineDesign, LobesNoTargetSeesComeFromTheLikePaint) {
  // 45as15 .. 45as110 are 15 deg and more from the gloss: the 800 and 3600 lobes (a clear coat)
  // see nothing there. Without --like they stay 0; with it they are the red metallic's.
  const auto targets = targets_of(*paint("silver-metallic.toml"), "astm-e2194");
  const DesignResult bare = design_paint(kExponents, targets);
  const auto red = fit_cosine_lobes(*paint("red-metallic.toml"), kExponents).params;
  const DesignResult like = design_paint(kExponents, targets, &red);
  ASSERT_EQ(bare.notes.size(), 2u);
  EXPECT_THAT(bare.notes[0], HasSubstr("exponent 800: no target sees its lobe"));
  EXPECT_THAT(bare.notes[0], HasSubstr("left at 0"));
  EXPECT_THAT(like.notes[1], HasSubstr("the --like paint's"));
  for (std::size_t i : {4u, 5u})
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(bare.params.kg[i][c], 0.0);
      EXPECT_EQ(like.params.kg[i][c], red.kg[i][c]);
      EXPECT_EQ(like.params.kdd[i][c], red.kdd[i][c]);
    }
  EXPECT_TRUE(bare.all_reached());
  EXPECT_TRUE(like.all_reached());  // the rest fitted around the kept gloss
  EXPECT_GT(red.kg[5].maxCoeff() + red.kg[4].maxCoeff(), 0.0);  // the red's clear coat is there to keep
  const auto other = fit_cosine_lobes(*paint("red-metallic.toml"), {2, 40, 800}).params;
  EXPECT_THROW(design_paint(kExponents, targets, &other), UsageError);
}

TEST(CosineDesign, UnreachableTargetsAreReportedWithTheReason) {
  auto t = targets_of(*paint("red-metallic.toml"), "astm-e2194");  // 45as15, 45as45, 45as110
  // A reverse flop: lighter far from the gloss than near it. Every lobe falls away from the
  // mirror direction, so no non-negative weights make it; the nearer targets still count.
  t[2].lab.L = t[0].lab.L + 20;
  DesignResult r = design_paint(kExponents, t);
  EXPECT_FALSE(r.all_reached());
  int missed = 0;
  for (const auto& a : r.angles) missed += a.reached ? 0 : 1;
  EXPECT_GE(missed, 1);
  for (const auto& a : r.angles) {
    if (!a.reached) {
      EXPECT_THAT(a.why, HasSubstr("non-negative"));
    }
  }
  // Outside the sRGB gamut: a chroma no linear sRGB reflectance has.
  auto g = targets_of(*paint("red-metallic.toml"), "astm-e2194");
  g[1].lab = {50, -20, -120};
  r = design_paint(kExponents, g);
  EXPECT_FALSE(r.angles[1].reached);
  EXPECT_THAT(r.angles[1].why, HasSubstr("outside the sRGB gamut"));
  EXPECT_THAT(design_table(r), HasSubstr("NOT REACHED"));
  EXPECT_FALSE(design_json(r)["all_reached"].get<bool>());
}

TEST(CosineDesign, TargetsFileErrorsNameTheLine) {
  const test::TempDir tmp;
  const fs::path dir = tmp.path();
  std::ofstream(dir / "t.toml") << "name = \"new-red\"\nbasis = \"b.json\"\n[[target]]\ngeometry = \"45as15\"\n"
                                   "lab = [60, 40, 20]\n[[target]]\ngeometry = \"45as110\"\nlab = [20, 15, 8]\n";
  const DesignTargets d = load_design_targets(dir / "t.toml");
  EXPECT_EQ(d.name, "new-red");
  ASSERT_TRUE(d.basis);
  EXPECT_EQ(*d.basis, dir / "b.json");
  ASSERT_EQ(d.targets.size(), 2u);
  EXPECT_EQ(d.targets[1].geometry.aspecular_deg, 110);
  std::ofstream(dir / "dup.toml") << "[[target]]\ngeometry = \"45as15\"\nlab = [60, 40, 20]\n[[target]]\n"
                                     "geometry = \"45as15\"\nlab = [61, 40, 20]\n";
  const std::string dup = test::error_message<ConfigError>([&] { load_design_targets(dir / "dup.toml"); });
  EXPECT_THAT(dup, HasSubstr("dup.toml:5"));
  EXPECT_THAT(dup, HasSubstr("a second target for 45as15"));
  std::ofstream(dir / "bad.toml") << "[[target]]\ngeometry = \"45as15\"\nlab = [60, 40]\n";
  EXPECT_THROW(load_design_targets(dir / "bad.toml"), ConfigError);
  std::ofstream(dir / "geo.toml") << "[[target]]\ngeometry = \"45at15\"\nlab = [60, 40, 20]\n";
  EXPECT_THROW(load_design_targets(dir / "geo.toml"), ConfigError);
  EXPECT_THROW(load_design_targets(dir / "missing.toml"), UsageError);
}

}  // namespace
}  // namespace paintlab::fit
