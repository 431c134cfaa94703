// Adaptive bracketing on the simulator: the planner, fed the merged radiance of the
// previous light position, drops exposures of the reference rig's 16-exposure bracket
// that add no unsaturated sphere pixel above the noise floor; the merge of the frames it
// keeps has the same signal-to-noise ratio as the merge of the full bracket (within 5 %)
// at every sphere pixel the full bracket measures.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "paintlab/acquisition/adaptive.h"
#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/core/config.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/world.h"
#include "sim_rigs.h"
#include "test_util.h"

using namespace paintlab;

namespace {

constexpr int kBits = 12;

// The reference rig's bracket: 16 exposures from 0.25 ms to 328 ms.
std::vector<double> reference_bracket() {
  std::vector<double> t;
  for (int i = 0; i < 16; ++i) t.push_back(0.25e-3 * std::pow(328.0 / 0.25, i / 15.0));
  return t;
}

struct Bracket {
  std::vector<Image<std::uint16_t>> frames;
  std::vector<double> exposures_s;
};

// One radiance render of the world at `angle`, exposed at every exposure (noise realisation
// by frame index, as the camera would give them one after the other).
Bracket capture(sim::SimWorld& world, double angle, const std::vector<double>& exposures, std::uint64_t first_frame) {
  ImageF radiance = world.render_at(angle, true);
  Bracket b;
  b.exposures_s = exposures;
  for (std::size_t j = 0; j < exposures.size(); ++j) {
    sim::ExposureSettings e;
    e.exposure_s = exposures[j];
    e.output_bits = kBits;
    e.frame_index = first_frame + j;
    b.frames.push_back(world.sensor().expose(radiance, e, 0));
  }
  return b;
}

acq::HdrResult merge(const acq::HdrMerger& merger, const Bracket& b, const std::vector<double>& keep) {
  std::vector<calib::StackFrame> stack;
  for (std::size_t j = 0; j < b.exposures_s.size(); ++j)
    if (std::find(keep.begin(), keep.end(), b.exposures_s[j]) != keep.end())
      stack.push_back({&b.frames[j], b.exposures_s[j]});
  return merger.merge(stack);
}

class AdaptiveSim : public ::testing::TestWithParam<std::string> {};

}  // namespace

TEST_P(AdaptiveSim, DropsExposuresWithoutLosingSignalToNoise) {
  RigConfig rig = RigConfig::parse(
      ConfigTable::parse_string(test::small_sim_rig(2, 10.0, 4, 320, 240), "rig.toml"), "rig.toml");
  sim::SimWorld world(sim::SimConfig::from_rig(rig));
  world.set_paint(sim::load_sim_paint(test::source_dir() / "paints" / (GetParam() + ".toml")));
  const sim::SensorParams& p = world.sensor().params();

  // The merge as the calibrated rig does it: black level, the noise model of the sensor,
  // a floor at 3 x read noise, saturation at the ADC's top.
  acq::HdrOptions options;
  options.black_dn = p.black_level_dn;
  options.saturation_dn = p.adc_max_dn() - 1;
  const double gain = p.gain0_dn_per_e();
  options.noise = {p.read_noise_e * gain, gain, "sim sensor truth"};
  options.floor_dn = 3.0 * p.read_noise_e * gain;
  const int w = rig.geometry.image_width_px, h = rig.geometry.image_height_px;
  acq::HdrMerger merger(acq::HdrCalibration{}, options, w, h, 1, kBits);

  // The sphere's pixels (the calibration gives the same outline).
  ImageF coverage = world.sphere_coverage();
  Image<std::uint8_t> mask(w, h, 1, 0);
  for (std::size_t i = 0; i < mask.size(); ++i) mask.data()[i] = coverage.data()[i] > 0.999f ? 1 : 0;

  acq::AdaptiveOptions ao;
  ao.linear_floor = options.floor_dn;
  ao.linear_saturation = options.saturation_dn - p.black_level_dn;
  ao.read_noise_dn = options.noise.read_noise_dn;
  ao.gain_dn_per_e = options.noise.gain_dn_per_e;
  acq::AdaptiveBracketing planner(ao, mask);

  const std::vector<double> bracket = reference_bracket();
  // The previous position (light 5 degrees earlier) measured with the full bracket.
  acq::HdrResult previous = merge(merger, capture(world, 40.0, bracket, 0), bracket);
  std::vector<double> keep = planner.choose(bracket, &previous.image);
  const Bracket now = capture(world, 45.0, bracket, 100);
  acq::HdrResult full = merge(merger, now, bracket);
  acq::HdrResult adaptive = merge(merger, now, keep);

  double saved_s = 0;
  for (double t : bracket)
    if (std::find(keep.begin(), keep.end(), t) == keep.end()) saved_s += t + p.readout_s;
  double bracket_s = 0;
  for (double t : bracket) bracket_s += t + p.readout_s;
  const ImageF& y_full = full.image.plane("Y");
  const ImageF& v_full = full.image.plane("var.Y");
  const ImageF& ok_full = full.image.plane("valid");
  const ImageF& y_ad = adaptive.image.plane("Y");
  const ImageF& v_ad = adaptive.image.plane("var.Y");
  const ImageF& ok_ad = adaptive.image.plane("valid");
  long long measured = 0, lost = 0;
  std::vector<double> ratio;
  double snr_full_sum = 0, snr_ad_sum = 0;
  for (std::size_t i = 0; i < mask.size(); ++i) {
    if (!mask.data()[i] || ok_full.data()[i] < 0.5f) continue;
    ++measured;
    if (ok_ad.data()[i] < 0.5f) {
      ++lost;
      continue;
    }
    const double snr_full = y_full.data()[i] / std::sqrt(v_full.data()[i]);
    const double snr_ad = y_ad.data()[i] / std::sqrt(v_ad.data()[i]);
    snr_full_sum += snr_full;
    snr_ad_sum += snr_ad;
    ratio.push_back(snr_ad / snr_full);
  }
  ASSERT_GT(measured, 1000);
  std::sort(ratio.begin(), ratio.end());
  const double median = ratio[ratio.size() / 2];
  const double p05 = ratio[ratio.size() / 20];
  std::cout << fmt::format("{}: kept {} of {} exposures, saved {:.3f} s of {:.3f} s per position; sphere pixels "
                           "measured {}, lost {}; SNR adaptive/full: mean {:.4f}, median {:.4f}, 5th percentile {:.4f}, "
                           "minimum {:.4f} (planned worst information loss {:.3f})\n",
                           GetParam(), keep.size(), bracket.size(), saved_s, bracket_s, measured, lost,
                           snr_ad_sum / snr_full_sum, median, p05, ratio.front(), planner.last_worst_loss());
  EXPECT_LT(keep.size(), bracket.size()) << "nothing was dropped";
  EXPECT_GE(bracket.size() - keep.size(), 2u);
  EXPECT_GT(saved_s, 0.0);
  EXPECT_LE(lost, measured / 1000) << "pixels the full bracket measures must stay measured";
  EXPECT_GT(snr_ad_sum / snr_full_sum, 0.95);
  EXPECT_GT(median, 0.95);
  EXPECT_GT(p05, 0.95);
}

INSTANTIATE_TEST_SUITE_P(Paints, AdaptiveSim, ::testing::Values("silver-metallic", "solid-blue"));

TEST(AdaptiveBracketing, FirstPositionAndForeignImagesGetTheFullBracket) {
  acq::AdaptiveOptions o;
  o.linear_floor = 4;
  o.linear_saturation = 4000;
  acq::AdaptiveBracketing planner(o, Image<std::uint8_t>(8, 8, 1, 1));
  const std::vector<double> bracket{0.001, 0.01, 0.1};
  EXPECT_EQ(planner.choose(bracket, nullptr), bracket);
  ExrImage other;  // no Y channel
  other.add("R", ImageF(8, 8, 1, 100.0f));
  EXPECT_EQ(planner.choose(bracket, &other), bracket);
  ExrImage wrong_size;
  wrong_size.add("Y", ImageF(4, 4, 1, 100.0f));
  EXPECT_EQ(planner.choose(bracket, &wrong_size), bracket);
}

TEST(AdaptiveBracketing, KeepsOnlyTheExposuresThatSeeTheRadianceRange) {
  acq::AdaptiveOptions o;
  o.linear_floor = 4;
  o.linear_saturation = 4000;
  o.margin = 1.0;
  o.max_information_loss = 0.0;  // the literal rule alone
  acq::AdaptiveBracketing planner(o, Image<std::uint8_t>());
  // Radiance 1e4 and 1e5 DN/s: 10 us puts both under the floor, 1 s saturates both;
  // 1 ms and 10 ms see them.
  ExrImage e;
  ImageF y(2, 1, 1);
  y.data()[0] = 1e4f;
  y.data()[1] = 1e5f;
  e.add("Y", y);
  const std::vector<double> bracket{1e-5, 1e-3, 1e-2, 1.0};
  EXPECT_EQ(planner.choose(bracket, &e), (std::vector<double>{1e-3, 1e-2}));
  EXPECT_EQ(planner.last_worst_loss(), 0.0);
  // With read-noise-limited values the information goes as t^2: 1 ms carries 1 % of each
  // pixel's (1e-6 / (1e-6 + 1e-4)), under a 5 % budget it goes.
  o.max_information_loss = 0.05;
  acq::AdaptiveBracketing budget(o, Image<std::uint8_t>());
  EXPECT_EQ(budget.choose(bracket, &e), (std::vector<double>{1e-2}));
  EXPECT_NEAR(budget.last_worst_loss(), 1e-6 / (1e-6 + 1e-4), 1e-4);
  // A pixel saturated even in the shortest exposure of the last bracket asks for it again.
  ImageF valid(2, 1, 1, 1.0f);
  ExrImage s = e;
  s.find("Y")->data()[1] = 4e8f;
  valid.data()[1] = 0.0f;
  s.add("valid", valid);
  EXPECT_EQ(planner.choose(bracket, &s).front(), 1e-5);
  EXPECT_THROW(acq::AdaptiveBracketing(acq::AdaptiveOptions{}, Image<std::uint8_t>()), UsageError);
}

namespace {

// Usable between 4 and 4000 linear DN, no margin, the literal rule alone.
acq::AdaptiveOptions literal_options() {
  acq::AdaptiveOptions o;
  o.linear_floor = 4;
  o.linear_saturation = 4000;
  o.margin = 1.0;
  o.max_information_loss = 0.0;
  return o;
}

}  // namespace

TEST(AdaptiveBracketing, AColourCameraIsPlannedOnItsMosaicSoEachColourKeepsItsExposures) {
  acq::AdaptiveBracketing planner(literal_options(), Image<std::uint8_t>());
  const std::vector<double> bracket{1e-5, 1e-3, 1e-2, 1.0};
  // What the runner stores of a colour position: R, G, B in linear sRGB, no Y: on its own the
  // planner cannot plan from it and keeps the full bracket.
  ExrImage stored;
  stored.add("R", ImageF(2, 1, 1, 1e4f));
  EXPECT_EQ(planner.choose(bracket, &stored), bracket);
  // Given the merger's mosaic, every site is planned as the pixel it is: a blue site of 1e2
  // DN/s needs 1 s next to a red one of 1e5 that needs 1 ms and 10 ms.
  auto mosaic = std::make_shared<ExrImage>();
  ImageF y(2, 1, 1);
  y.data()[0] = 1e5f;
  y.data()[1] = 1e2f;
  mosaic->add("Y", y);
  planner.predict_from([mosaic] { return mosaic; });
  EXPECT_EQ(planner.choose(bracket, &stored), (std::vector<double>{1e-3, 1e-2, 1.0}));
  // The first position (nothing stored yet) still takes the full bracket.
  EXPECT_EQ(planner.choose(bracket, nullptr), bracket);
}

TEST(AdaptiveBracketing, AFilterWheelPlansEachFiltersBracketFromThatFiltersLastMerge) {
  acq::AdaptiveBracketing planner(literal_options(), Image<std::uint8_t>());
  const std::vector<double> bracket{1e-5, 1e-3, 1e-2, 1.0};
  // Red bright (1e5 DN/s: 1 ms and 10 ms), blue dark (1e2: only 1 s sees it).
  std::array<std::shared_ptr<ExrImage>, 3> merged;
  const float rate[3] = {1e5f, 1e4f, 1e2f};
  for (int c = 0; c < 3; ++c) {
    merged[c] = std::make_shared<ExrImage>();
    merged[c]->add("Y", ImageF(2, 1, 1, rate[c]));
  }
  planner.predict_per_filter([merged](int c) { return std::shared_ptr<const ExrImage>(merged[c]); });
  ExrImage stored;  // the R, G, B the session keeps
  stored.add("R", ImageF(2, 1, 1, 1.0f));
  EXPECT_EQ(planner.choose_for_filter(0, bracket, &stored), (std::vector<double>{1e-3, 1e-2}));
  EXPECT_EQ(planner.choose_for_filter(2, bracket, &stored), (std::vector<double>{1.0}));
  EXPECT_EQ(planner.choose_for_filter(2, bracket, nullptr), bracket);  // the first position
}
