// Extraction and binning of simulated HDR frames against the simulator's truth, and the
// fit of what comes out (the pipeline from HDR images on, with the truth calibration).
#include "paintlab/fitting/extraction.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/colour.h"
#include "paintlab/core/error.h"
#include "paintlab/core/image_io.h"
#include "paintlab/fitting/coverage.h"
#include "paintlab/fitting/ct_fit.h"
#include "paintlab/sim/paint.h"
#include "sim_session.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

using test::NearRel;

brdf::PaintSpec silver() { return brdf::load_paint_file(test::source_dir() / "paints/silver-metallic.toml"); }

// z-scores of the measured bins against the truth at their mean coordinates.
struct ZStats {
  double mean = 0, sd = 0;
  std::size_t n = 0;
};
ZStats zscores(const BinnedTable& t, const brdf::Brdf& truth, std::uint32_t min_count) {
  double s = 0, s2 = 0;
  std::size_t n = 0;
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b) {
    if (t.table.state(b) != brdf::BinState::Measured || t.table.count(b) < min_count) continue;
    if (region_of_bin(b) == Region::Peak) continue;  // within-bin curvature of the clear coat: see docs
    const Eigen::Vector3d c = t.table.mean_coords(b);
    const brdf::DirectionPair d = brdf::directions_from_half_diff({c[0], 0.0, c[1], c[2]});
    const brdf::Rgb f = truth.eval(d.wi, d.wo);
    const brdf::Rgb v = t.table.value(b), noise = t.noise(b);
    for (int ch = 0; ch < 3; ++ch) {
      const double z = (v[ch] - f[ch]) / std::sqrt(noise[ch] / t.table.count(b));
      s += z;
      s2 += z * z;
      ++n;
    }
  }
  ZStats z;
  z.n = n;
  z.mean = s / n;
  z.sd = std::sqrt(s2 / n - z.mean * z.mean);
  return z;
}

TEST(Extraction, BinnedSimulatedFramesAgreeWithTheTruthWithinTheNoise) {
  const brdf::PaintSpec spec = silver();
  // A small rig image (320 x 240, the sphere about 100 pixels across) every 3 degrees keeps
  // the rendering short; the z-scores need many bins, not many samples per bin.
  test_support::SimSessionOptions o;
  o.sparkle = false;
  o.width_px = 320;
  o.height_px = 240;
  o.focal_length_mm = 12.5;
  o.step_deg = 3.0;
  auto session = test_support::make_sim_session(sim::sim_paint(spec), o);
  const calib::RigCalibration cal = calib::RigCalibration::load(session->calibration_dir());
  ExtractionStats stats;
  ExtractionOptions eo;
  eo.threads = 2;
  const BinnedTable t = bin_frames(session->frames, cal, eo, {}, &stats);
  const std::size_t measured = t.table.count_in_state(brdf::BinState::Measured);
  const std::string said = stats.describe(measured);
  std::printf("extraction: %s (%llu sphere pixels)\n", said.c_str(),
              static_cast<unsigned long long>(stats.sphere_pixels));
  EXPECT_EQ(said, fmt::format("{} images: {} samples (0 invalid, {} grazing, 0 next to invalid, 0 blurred pixels "
                              "skipped; 0 sharpened, 0 too sharp to correct) in {} measured bins",
                              session->frames.size(), t.samples_binned, stats.grazing, measured));
  EXPECT_EQ(stats.images, session->frames.size());
  EXPECT_EQ(stats.samples, t.samples_binned);
  EXPECT_EQ(stats.invalid, 0u);
  EXPECT_GT(stats.samples, 100000u);
  std::printf("%s", coverage(t.table).describe().c_str());
  const auto truth = brdf::make_brdf(spec);
  const ZStats z = zscores(t, *truth, 2);
  std::printf("z-scores of %zu bin values against the truth: mean %.3f, sd %.3f\n", z.n, z.mean, z.sd);
  EXPECT_LT(std::abs(z.mean), 0.1);
  EXPECT_GT(z.sd, 0.85);
  EXPECT_LT(z.sd, 1.2);
}

// The lens blur and noise floor rules (docs/fitting.md "Lens blur and the noise floor") on a
// few frames of a blurred, censored sweep: what each rule does is counted, the options
// that turn them off leave every pixel to the plain extraction, and bad settings name the
// field. (Their accuracy: fitting_sim's SimPipeline.DarkMetallicUnderLensBlurAndANoiseFloor.)
TEST(Extraction, LensBlurAndNoiseFloorRulesAreCountedAndCanBeTurnedOff) {
  test_support::SimSessionOptions o;
  o.sparkle = false;
  o.width_px = 320;
  o.height_px = 240;
  o.focal_length_mm = 25.0;
  o.start_deg = 30.0;
  o.stop_deg = 150.0;
  o.step_deg = 60.0;
  o.psf_sigma_px = 0.5;
  o.read_noise_white = 3e-4;
  auto session = test_support::make_sim_session(
      sim::sim_paint(brdf::load_paint_file(test::source_dir() / "paints/dark-metallic.toml")), o);
  const calib::RigCalibration cal = calib::RigCalibration::load(session->calibration_dir());
  ExtractionOptions off;
  off.threads = 2;
  off.valid_margin_px = 0;
  EXPECT_DOUBLE_EQ(blur_sigma_to_correct(off, cal), 0.0);  // opt-in
  ExtractionOptions on = off;
  on.valid_margin_px = ExtractionOptions{}.valid_margin_px;  // on by default
  on.blur_sigma_px = -1.0;
  EXPECT_DOUBLE_EQ(blur_sigma_to_correct(on, cal), 0.5);  // the light calibration's
  ExtractionStats with, without;
  bin_frames(session->frames, cal, on, {}, &with);
  bin_frames(session->frames, cal, off, {}, &without);
  std::printf("rules on: %s\nrules off: %s\n", with.describe(0).c_str(), without.describe(0).c_str());
  EXPECT_GT(with.deblurred, 100u);
  EXPECT_GT(with.unresolved, 0u);     // the clear coat's highlight, a few pixels across
  EXPECT_EQ(with.blurred, 0u);        // no invalid neighbour within the 2 px margin
  EXPECT_GT(with.near_invalid, 100u);
  EXPECT_EQ(without.deblurred + without.unresolved + without.blurred + without.near_invalid, 0u);
  EXPECT_EQ(with.samples + with.blurred + with.near_invalid, without.samples);
  EXPECT_EQ(with.invalid, without.invalid);
  const Json j = with.to_json();
  EXPECT_EQ(j["near_invalid"], with.near_invalid);
  EXPECT_EQ(j["blurred"], with.blurred);
  EXPECT_EQ(j["deblurred"], with.deblurred);
  EXPECT_EQ(j["unresolved"], with.unresolved);
  ExtractionOptions bad;
  bad.max_blur_correction = 0.0;
  EXPECT_THROW(bad.check(), OptionError);
  bad = {};
  bad.valid_margin_px = 11;
  try {
    bad.check();
    ADD_FAILURE();
  } catch (const OptionError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("valid_margin_px"));
  }
}

TEST(Extraction, ImagesOfTheWrongSizeOrWithoutRadianceAreRejected) {
  test_support::SimSessionOptions o;
  o.width_px = 320;
  o.height_px = 240;
  o.focal_length_mm = 12.5;
  o.start_deg = o.stop_deg = 90.0;
  auto session = test_support::make_sim_session(sim::sim_paint(silver()), o);
  const calib::RigCalibration cal = calib::RigCalibration::load(session->calibration_dir());
  const SphereSampler sampler(cal);
  SampleBatch out;
  ExrImage small;
  small.add("Y", ImageF(10, 10));
  EXPECT_THROW(sampler.extract(small, 0.0, out, "small.exr"), DataError);
  ExrImage nothing;
  nothing.add("Z", ImageF(o.width_px, o.height_px));
  try {
    sampler.extract(nothing, 0.0, out, "nothing.exr");
    ADD_FAILURE();
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("nothing.exr: no radiance channels"));
  }
  // A calibration folder without the light calibration cannot extract.
  std::filesystem::remove(session->calibration_dir() / calib::kLightFile);
  EXPECT_THROW(SphereSampler(calib::RigCalibration::load(session->calibration_dir())), CalibrationError);
}

// At the filter-array sites (docs/fitting.md "Fitting a Bayer camera at its sites") a pixel
// gives the colour its filter measured and nothing else: a simulated frame in camera RGB
// whose two interpolated colours at every site are spoiled (x3) gives, colour by colour,
// exactly the values and variances of the clean frame at that colour's sites, in pixel
// order; the spoiled values reach no table. GenICam's BayerGR: G R / B G.
TEST(Extraction, AtTheFilterArraySitesEachPixelGivesItsOwnColourOnly) {
  test_support::SimSessionOptions o;
  o.sparkle = false;
  o.width_px = 320;
  o.height_px = 240;
  o.focal_length_mm = 12.5;
  o.start_deg = o.stop_deg = 60.0;
  o.psf_sigma_px = 0.5;  // the light calibration states it: the blur correction below
  auto session = test_support::make_sim_session(
      sim::sim_paint(brdf::load_paint_file(test::source_dir() / "paints/red-metallic.toml")), o);
  const calib::RigCalibration cal = calib::RigCalibration::load(session->calibration_dir());
  ExrImage clean = read_exr(session->frames[0].path);
  clean.attributes["paintlab.colour_space"] = colour::kCameraRgb;
  ExrImage spoiled = clean;
  spoiled.attributes["paintlab.cfa"] = "GR";
  const int block[2][2] = {{1, 0}, {2, 1}};
  const char* names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c) {
    ImageF& v = *spoiled.find(names[c]);
    ImageF& var = *spoiled.find(std::string("var.") + names[c]);
    for (int y = 0; y < o.height_px; ++y)
      for (int x = 0; x < o.width_px; ++x)
        if (block[y & 1][x & 1] != c) {
          v.data()[y * o.width_px + x] *= 3.0f;
          var.data()[y * o.width_px + x] *= 9.0f;
        }
  }
  ExtractionOptions plain;
  plain.threads = 2;
  ExtractionOptions at_sites = plain;
  at_sites.cfa_sites = true;
  SampleBatch all;
  const ExtractionStats whole = SphereSampler(cal, plain).extract(clean, 60.0, all, "clean.exr");
  std::array<SampleBatch, 3> sites;
  const SphereSampler sampler(cal, at_sites);
  const ExtractionStats by_site = sampler.extract_sites(spoiled, 60.0, sites, "spoiled.exr");
  EXPECT_EQ(by_site.samples, whole.samples);
  ASSERT_EQ(sites[0].size() + sites[1].size() + sites[2].size(), all.size());
  // A quarter of the pixels are red, half green, a quarter blue.
  EXPECT_NEAR(static_cast<double>(sites[1].size()) / static_cast<double>(all.size()), 0.5, 0.02);
  EXPECT_NEAR(static_cast<double>(sites[0].size()) / static_cast<double>(all.size()), 0.25, 0.02);
  std::array<std::size_t, 3> next{0, 0, 0};
  std::size_t matched = 0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const SampleBatch& s = sites[static_cast<std::size_t>(c)];
      const std::size_t k = next[static_cast<std::size_t>(c)];
      if (k >= s.size() || s.theta_h[k] != all.theta_h[i] || s.theta_d[k] != all.theta_d[i] ||
          s.phi_d[k] != all.phi_d[i])
        continue;
      for (int j = 0; j < 3; ++j) {  // the site's own value in all three channels
        EXPECT_EQ(s.value[3 * k + static_cast<std::size_t>(j)], all.value[3 * i + static_cast<std::size_t>(c)]);
        EXPECT_EQ(s.variance[3 * k + static_cast<std::size_t>(j)], all.variance[3 * i + static_cast<std::size_t>(c)]);
      }
      ++next[static_cast<std::size_t>(c)];
      ++matched;
      break;
    }
  }
  EXPECT_EQ(matched, all.size());

  // The lens-blur correction at the sites reads only the nearest sites of a pixel's own
  // colour: the spoiled frame gives what the clean one gives, and the highlight is sharpened.
  ExtractionOptions deblurred = at_sites;
  deblurred.blur_sigma_px = -1.0;
  ExrImage clean_sites = clean;
  clean_sites.attributes["paintlab.cfa"] = "GR";
  std::array<SampleBatch, 3> a, b;
  const SphereSampler sharpening(cal, deblurred);
  EXPECT_DOUBLE_EQ(sharpening.blur_sigma_px(), 0.5);
  const ExtractionStats sa = sharpening.extract_sites(clean_sites, 60.0, a, "clean.exr");
  const ExtractionStats sb = sharpening.extract_sites(spoiled, 60.0, b, "spoiled.exr");
  EXPECT_GT(sa.deblurred, 100u);
  EXPECT_EQ(sa.deblurred, sb.deblurred);
  EXPECT_EQ(sa.unresolved, sb.unresolved);
  for (std::size_t c = 0; c < 3; ++c) {
    ASSERT_EQ(a[c].size(), b[c].size());
    EXPECT_EQ(a[c].value, b[c].value) << "colour " << c;
    EXPECT_EQ(a[c].variance, b[c].variance) << "colour " << c;
  }

  // An image without the arrangement, one that says it is sRGB without a colour calibration
  // to invert (this folder has no colour.json), and options that compare a pixel with its
  // neighbours (other colours at the sites) are refused, naming what is wrong.
  auto refused = [&](const ExrImage& img, const char* what) {
    try {
      sampler.extract_sites(img, 60.0, sites, "frame.exr");
      ADD_FAILURE() << what;
    } catch (const DataError& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(what));
    }
  };
  refused(clean, "frame.exr: not the colour image of a Bayer camera");
  ExrImage srgb = spoiled;
  srgb.attributes["paintlab.colour_space"] = colour::kLinearSrgb;
  refused(srgb, "no colour.json");
  EXPECT_THROW(sampler.extract(spoiled, 60.0, all, "spoiled.exr"), DataError);
  ExtractionOptions bad = at_sites;
  bad.variance = VarianceModel::Local;
  EXPECT_THROW(bad.check(), OptionError);
}

}  // namespace
}  // namespace paintlab::fit
