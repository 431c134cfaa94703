// A colour camera on the simulated rig through the real driver: the simulated GigE camera
// serves the Bayer formats, the sensor samples the scene's RGB through the colour-filter array
// after the camera's own channel mix, and every site of the mosaic carries what the sensor
// predicts for its colour (GigE Vision on 127.0.0.1:3956: RESOURCE_LOCK gige).
#include <gtest/gtest.h>

#include <cmath>

#include "paintlab/acquisition/demosaic.h"
#include "paintlab/core/rig.h"
#include "sim_devices.h"
#include "sim_rigs.h"
#include "test_util.h"

namespace paintlab {
namespace {

// A warm LED and a camera whose channels are not sRGB's: what reaches each site differs in a
// way the test can predict.
const char* kColourSim =
    "[sim]\nseed = 7\n[sim.led]\ncolor = [1.0, 0.6, 0.3]\n[sim.camera]\n"
    "rgb_matrix = [0.8, 0.25, -0.05, 0.1, 0.85, 0.05, 0.02, 0.2, 0.78]\nrgb_gain = [0.9, 1.0, 1.4]\n";

TEST(SimRigColour, EveryBayerArrangementRecordsTheCameraChannelOfEachSite) {
  test::TempDir dir;
  test::write_text(dir / "rig.toml", test::small_sim_rig(5, 10.0, 4, 320, 240, kColourSim));
  const RigConfig rig = RigConfig::load(dir / "rig.toml");
  test::SimDevices d = test::open_sim_devices(rig);
  ASSERT_TRUE(d.turntable->move_to(30.0));
  ASSERT_TRUE(d.turntable->wait_settled(10.0));
  ASSERT_TRUE(d.light->on());

  sim::SimWorld& w = d.sim->world();
  sim::RenderOptions rgb;
  rgb.mono = false;
  const ImageF scene = w.render_at(30.0, true, rgb);
  const auto& truth = w.config().camera;
  const auto camera_channel = [&](int x, int y, int j) {
    double v = 0;
    for (int c = 0; c < 3; ++c)
      v += truth.rgb_matrix[static_cast<std::size_t>(3 * j + c)] * scene.at(x, y, c);
    return truth.rgb_gain[static_cast<std::size_t>(j)] * std::max(v, 0.0);
  };
  // An exposure that puts the brightest channel at the sphere's centre near half the ADC range.
  const double full = w.config().sensor.adc_max_dn() - w.config().sensor.black_level_dn;
  double rate = 0;  // DN per second of the brightest camera channel at the centre
  for (int j = 0; j < 3; ++j)
    rate = std::max(rate, w.sensor().expected_raw(camera_channel(160, 120, j), 160, 120, 1.0, 0.0) -
                              w.config().sensor.black_level_dn);
  ASSERT_GT(rate, 0.0);
  ASSERT_TRUE(d.camera->set_exposure(0.5 * full / rate));
  for (dev::PixelFormat format : {dev::PixelFormat::BayerRG16, dev::PixelFormat::BayerGR12,
                                  dev::PixelFormat::BayerGB16, dev::PixelFormat::BayerBG8}) {
    SCOPED_TRACE(dev::to_string(format));
    ASSERT_TRUE(d.camera->set_pixel_format(format));
    auto f = d.camera->capture(20.0);
    ASSERT_TRUE(f) << f.error().what();
    EXPECT_EQ(f->meta.format, format);
    ASSERT_EQ(f->pixels.channels(), 1);
    const dev::CfaPattern cfa = dev::cfa_pattern(format);
    const double to_bits = std::ldexp(1.0, dev::bit_depth(format) - w.config().sensor.adc_bits);
    // Per colour, the mean over a block at the sphere's centre against the sensor's prediction.
    double got[3] = {0, 0, 0}, want[3] = {0, 0, 0};
    for (int y = 112; y < 128; ++y)
      for (int x = 152; x < 168; ++x) {
        const int j = dev::cfa_colour(cfa, x & 1, y & 1);
        got[j] += f->pixels.at(x, y);
        want[j] += w.sensor().expected_raw(camera_channel(x, y, j), x, y, f->meta.exposure_s, f->meta.gain_db) *
                   to_bits;
      }
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(got[j] / want[j], 1.0, 0.03) << "channel " << j;
    // Demosaiced, the block at the centre has the camera's colour of the scene there.
    const Image<std::uint16_t> colour = acq::demosaic(f->pixels, cfa, acq::DemosaicMethod::Bilinear);
    ASSERT_EQ(colour.channels(), 3);
    const double black = w.config().sensor.black_level_dn * to_bits;
    double sum[3] = {0, 0, 0}, truth_sum[3] = {0, 0, 0};
    for (int y = 112; y < 128; ++y)
      for (int x = 152; x < 168; ++x)
        for (int j = 0; j < 3; ++j) {
          sum[j] += colour.at(x, y, j) - black;
          truth_sum[j] += camera_channel(x, y, j);
        }
    EXPECT_NEAR((sum[0] / sum[1]) / (truth_sum[0] / truth_sum[1]), 1.0, 0.03);
    EXPECT_NEAR((sum[2] / sum[1]) / (truth_sum[2] / truth_sum[1]), 1.0, 0.03);
  }
}

}  // namespace
}  // namespace paintlab
