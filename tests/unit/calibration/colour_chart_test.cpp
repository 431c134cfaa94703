// A ColorChecker on the simulated rig: the simulator renders the chart (the reference's colours
// in linear sRGB, lit by a warm LED) through a camera whose channels are not sRGB's, with the
// sensor's noise; the chart finder locates it and measures its patches, in any orientation the
// grid allows, and the colour matrix fitted on them meets the chart targets.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "paintlab/calibration/colour.h"
#include "paintlab/core/error.h"
#include "paintlab/sim/scene_render.h"
#include "sim_scenes.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::calib;
using ::testing::HasSubstr;

namespace {

ChartReference load_colorchecker() { return ChartReference::load(test::data_dir() / "colorchecker" / "ColorChecker.cie"); }

// The reference's patches as the simulator's chart: linear sRGB reflectances.
sim::ColourChart chart_of(const ChartReference& ref) {
  sim::ColourChart chart;
  chart.patch_rgb = ref.srgb_reflectances();
  return chart;
}

struct ColourRig {
  sim::SimConfig config;
  std::unique_ptr<sim::SimWorld> world;
  ColourRig() : config(calib::testing::sim_rig_config()) {
    config.camera.rgb_matrix = {0.8, 0.25, -0.05, 0.1, 0.85, 0.05, 0.02, 0.2, 0.78};
    config.camera.rgb_gain = {0.6, 1.0, 0.8};
    config.led.color = {1.0, 0.9, 0.75};
    world = std::make_unique<sim::SimWorld>(config);
  }
  // camera RGB per scene sRGB: diag(gain) * matrix * diag(LED colour)
  Eigen::Matrix3d camera_from_srgb() const {
    Eigen::Matrix3d m;
    for (int j = 0; j < 3; ++j)
      for (int c = 0; c < 3; ++c)
        m(j, c) = config.camera.rgb_gain[static_cast<std::size_t>(j)] *
                  config.camera.rgb_matrix[static_cast<std::size_t>(3 * j + c)] * config.led.color[static_cast<std::size_t>(c)];
    return m;
  }
  // The chart through the sensor (three channels, noise), linearised and black-subtracted.
  ImageF shoot(const sim::ColourChart& chart, int view = 0) {
    sim::SceneRequest q;
    q.kind = sim::SceneKind::ColourChart;
    q.chart = chart;
    q.channels = 3;
    q.view = view;
    q.views = 3;
    const sim::SceneRender scene = sim::render_scene(*world, q);
    sim::ExposureSettings e;
    e.exposure_s = q.exposure_s;
    e.frame_index = 1;
    e.output_bits = config.sensor.adc_bits;
    const Image<std::uint16_t> raw = world->sensor().expose(scene.radiance, e);
    const auto& sp = config.sensor;
    const double span = sp.adc_max_dn() - sp.black_level_dn;
    ImageF out(raw.width(), raw.height(), 3);
    for (std::size_t i = 0; i < raw.size(); ++i) {
      const double x = (raw.values()[i] - sp.black_level_dn) / span;
      out.values()[i] = static_cast<float>((x > 0 ? world->response().inverse(x) : x) * span);
    }
    return out;
  }
};

ImageF flipped(const ImageF& img, int code) {
  cv::Mat m(img.height(), img.width(), CV_32FC3, const_cast<float*>(img.data())), f;
  cv::flip(m, f, code);
  ImageF out(img.width(), img.height(), 3);
  std::copy(f.ptr<float>(0), f.ptr<float>(0) + out.size(), out.data());
  return out;
}

}  // namespace

TEST(ColourChart, TheSimulatedChartIsFoundMeasuredAndCalibratedWithinTheTargets) {
  const ChartReference ref = load_colorchecker();
  ColourRig rig;
  const ImageF image = rig.shoot(chart_of(ref));
  const ChartDetection found = find_colour_chart(image, ref, 0.999 * (rig.config.sensor.adc_max_dn() - rig.config.sensor.black_level_dn));
  ASSERT_EQ(found.patches.size(), 24u);
  EXPECT_GT(found.pitch_px, 40.0);
  EXPECT_GT(found.orientation_margin, 10.0);
  // Every patch's camera values are the camera's view of its reference colour, up to one scale.
  const Eigen::Matrix3d cam = rig.camera_from_srgb();
  const std::vector<colour::Xyz> xyz = ref.xyz_d65();
  std::vector<double> scale;
  for (std::size_t i = 0; i < 24; ++i) {
    const colour::Rgb expected = cam * colour::xyz_to_srgb(xyz[i]);
    scale.push_back(found.patches[i].rgb.dot(expected) / expected.squaredNorm());
    EXPECT_FALSE(found.patches[i].clipped) << ref.patches[i];
    EXPECT_GT(found.patches[i].pixels, 200) << ref.patches[i];
  }
  std::vector<double> sorted = scale;
  std::sort(sorted.begin(), sorted.end());
  const double k = sorted[12];
  for (std::size_t i = 0; i < 24; ++i) {
    const colour::Rgb expected = k * cam * colour::xyz_to_srgb(xyz[i]);
    EXPECT_LT((found.patches[i].rgb - expected).norm(), 0.02 * expected.norm() + 2.0) << ref.patches[i];
  }
  // The chart targets on the noisy simulator: mean dE00 <= 0.5, max <= 1.5.
  const ColourCalibration cal = fit_colour(ref, found.patches, {});
  std::printf("simulated chart: %s\n", cal.describe().c_str());
  EXPECT_LT(cal.mean_de00, 0.5);
  EXPECT_LT(cal.max_de00, 1.5);
  // The matrix undoes the camera (and the LED's tint): XYZ = srgb_to_xyz * cam^-1 / k.
  const Eigen::Matrix3d expected = colour::srgb_to_xyz_matrix() * cam.inverse() / k;
  EXPECT_LT((cal.matrix - expected).cwiseAbs().maxCoeff(), 0.02 * expected.cwiseAbs().maxCoeff());
}

TEST(ColourChart, TurnedOrMirroredTheSamePatchesAreFound) {
  const ChartReference ref = load_colorchecker();
  ColourRig rig;
  const ImageF image = rig.shoot(chart_of(ref), 1);
  const ChartDetection upright = find_colour_chart(image, ref);
  for (int code : {-1, 0, 1}) {  // turned half way; mirrored top-bottom; mirrored left-right
    SCOPED_TRACE(code);
    const ChartDetection other = find_colour_chart(flipped(image, code), ref);
    for (std::size_t i = 0; i < 24; ++i)
      EXPECT_LT((other.patches[i].rgb - upright.patches[i].rgb).norm(), 0.01 * upright.patches[i].rgb.norm() + 2.0)
          << ref.patches[i];
  }
}

TEST(ColourChart, NoChartOrAMonochromeImageIsAnErrorSayingWhat) {
  const ChartReference ref = load_colorchecker();
  const ImageF grey(640, 480, 3, 100.0f);
  EXPECT_THAT(test::error_message<CalibrationError>([&] { find_colour_chart(grey, ref); }),
              HasSubstr("no ColorChecker 24 found in the 640x480 image"));
  const ImageF mono(640, 480, 1, 100.0f);
  EXPECT_THAT(test::error_message<DataError>([&] { find_colour_chart(mono, ref); }),
              HasSubstr("the image has 1 channel(s); the chart needs colour (3)"));
}
