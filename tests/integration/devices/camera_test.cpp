// AravisCamera (the real driver, GigE Vision on 127.0.0.1) against our simulated camera
// (Aravis' fake in-process with our GenICam XML and fill callback) and against Aravis' own
// arv-fake-gv-camera-0.8 (older feature names, packet loss). Every test here holds port
// 3956: ctest runs them under RESOURCE_LOCK gige.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "paintlab/devices/aravis_camera.h"
#include "paintlab/sim/peers/gige_camera.h"
#include "process_util.h"
#include "fake_rig.h"
#include "test_util.h"

namespace paintlab {
namespace {

using dev::AravisCamera;
using dev::AravisCameraConfig;
using dev::PixelFormat;

double wall_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

class SimCamera : public ::testing::Test {
 protected:
  void SetUp() override {
    sim::GigeCameraOptions o;
    o.width = 160;
    o.height = 120;
    o.readout_s = 0.005;
    peer_ = std::make_unique<sim::GigeCamera>(o, clock_);
    peer_->start();
  }
  void TearDown() override {
    cam_.reset();
    peer_.reset();
  }
  AravisCamera& open(AravisCameraConfig c = {}) {
    c.id = "127.0.0.1";
    c.packet_size = 1400;
    auto r = AravisCamera::open(c);
    if (!r) throw r.error();
    cam_ = std::move(*r);
    return *cam_;
  }
  sim::FrameRequest request(const dev::Frame& f, double black = 0) const {
    sim::FrameRequest r;
    r.exposure_s = f.meta.exposure_s;
    r.gain_db = f.meta.gain_db;
    r.black_level = black;
    r.format = f.meta.format;
    r.width = f.pixels.width();
    r.height = f.pixels.height();
    return r;
  }
  // Every pixel equals the analytic prediction for the frame's applied exposure and gain.
  void expect_prediction(const dev::Frame& f, double black = 0) const {
    sim::FrameRequest r = request(f, black);
    int mismatches = 0;
    for (int y = 0; y < f.pixels.height(); ++y)
      for (int x = 0; x < f.pixels.width(); ++x)
        if (f.pixels.at(x, y) != sim::analytic_pixel(r, x, y)) ++mismatches;
    EXPECT_EQ(mismatches, 0);
  }

  test::FakeClock clock_;
  std::unique_ptr<sim::GigeCamera> peer_;
  std::unique_ptr<AravisCamera> cam_;
};

TEST_F(SimCamera, ModernFeatureNamesAppliedValuesAndPixels) {
  AravisCamera& cam = open();
  EXPECT_THAT(cam.model(), ::testing::HasSubstr("PaintlabSim"));
  EXPECT_EQ(cam.serial(), "PAINTLAB-SIM-1");
  auto range = cam.exposure_range();
  ASSERT_TRUE(range);
  EXPECT_NEAR(range->min_s, 10e-6, 1e-12);
  EXPECT_NEAR(range->max_s, 10.0, 1e-9);
  auto e = cam.set_exposure(0.0123456);
  ASSERT_TRUE(e) << e.error().what();
  EXPECT_NEAR(*e, 0.012345, 1.5e-6);  // whole microseconds
  auto g = cam.set_gain_db(6.0);
  ASSERT_TRUE(g) << g.error().what();
  EXPECT_NEAR(*g, 6.0, 1e-9);
  double v0 = clock_.now_s();
  auto f = cam.capture(5.0);
  ASSERT_TRUE(f) << f.error().what();
  EXPECT_EQ(f->pixels.width(), 160);
  EXPECT_EQ(f->pixels.height(), 120);
  EXPECT_EQ(f->meta.format, PixelFormat::Mono16);
  EXPECT_DOUBLE_EQ(f->meta.exposure_s, *e);
  EXPECT_DOUBLE_EQ(f->meta.gain_db, *g);
  expect_prediction(*f);
  // A corner value worked out by hand: rate 1e5 DN/s * 0.25 at (0, 0), 2x amplitude at 6 dB.
  EXPECT_NEAR(f->pixels.at(0, 0), 1e5 * 0.25 * *e * std::pow(10.0, 0.3), 0.51);
  // The fill advanced the sim clock by exposure + readout.
  EXPECT_NEAR(clock_.now_s() - v0, *e + 0.005, 1e-9);
  EXPECT_EQ(cam.bad_buffers(), 0);
}

TEST_F(SimCamera, GainIsAppliedInTenthsOfADecibel) {
  AravisCamera& cam = open();
  auto g = cam.set_gain_db(2.54);
  ASSERT_TRUE(g);
  EXPECT_NE(*g, 2.54);
  EXPECT_NEAR(*g, 2.5, 0.1 + 1e-9);
  auto f = cam.capture(5.0);
  ASSERT_TRUE(f);
  EXPECT_DOUBLE_EQ(f->meta.gain_db, *g);
  expect_prediction(*f);
  EXPECT_FALSE(cam.set_gain_db(60.0));
  EXPECT_FALSE(cam.set_exposure(20.0));
}

TEST_F(SimCamera, Mono12AndMono8CarryTheirBitDepth) {
  AravisCameraConfig c;
  c.pixel_format = PixelFormat::Mono12;
  AravisCamera& cam = open(c);
  ASSERT_TRUE(cam.set_exposure(0.03));  // up to 3000 DN: inside 12 bits
  auto f = cam.capture(5.0);
  ASSERT_TRUE(f) << f.error().what();
  EXPECT_EQ(f->meta.format, PixelFormat::Mono12);
  expect_prediction(*f);
  EXPECT_GT(f->pixels.at(159, 119), 2900);
  ASSERT_TRUE(cam.set_exposure(0.1));  // clips at 4095
  f = cam.capture(5.0);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->pixels.at(159, 119), 4095);
  expect_prediction(*f);

  ASSERT_TRUE(cam.set_pixel_format(PixelFormat::Mono8));
  auto pf = cam.pixel_format();
  ASSERT_TRUE(pf);
  EXPECT_EQ(*pf, PixelFormat::Mono8);
  ASSERT_TRUE(cam.set_exposure(0.002));
  f = cam.capture(5.0);
  ASSERT_TRUE(f) << f.error().what();
  EXPECT_EQ(f->meta.format, PixelFormat::Mono8);
  expect_prediction(*f);
  EXPECT_EQ(f->pixels.at(159, 119), 200);
}

TEST_F(SimCamera, BlackLevelFromTheRigConfig) {
  AravisCameraConfig c;
  c.black_level = 64;
  AravisCamera& cam = open(c);
  ASSERT_TRUE(cam.set_exposure(0.001));
  auto f = cam.capture(5.0);
  ASSERT_TRUE(f);
  expect_prediction(*f, 64);
  EXPECT_EQ(f->pixels.at(0, 0), 64 + 25);
}

TEST_F(SimCamera, SoftwareTriggerOneFramePerCaptureAndIncreasingIds) {
  AravisCamera& cam = open();
  ASSERT_TRUE(cam.set_exposure(0.001));
  auto a = cam.capture(5.0);
  ASSERT_TRUE(a);
  std::uint64_t filled = peer_->frames_filled();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(peer_->frames_filled(), filled) << "frames without a trigger";
  auto b = cam.capture(5.0);
  ASSERT_TRUE(b);
  EXPECT_EQ(peer_->frames_filled(), filled + 1);
  EXPECT_NE(b->meta.frame_id, a->meta.frame_id);
  EXPECT_GT(b->meta.timestamp_ns, a->meta.timestamp_ns);
}

TEST_F(SimCamera, SettleFramesAreDiscardedAfterAnExposureChange) {
  AravisCameraConfig c;
  c.settle_frames = 2;
  AravisCamera& cam = open(c);
  ASSERT_TRUE(cam.set_exposure(0.004));
  std::uint64_t before = peer_->frames_filled();
  auto f = cam.capture(5.0);
  ASSERT_TRUE(f);
  EXPECT_EQ(peer_->frames_filled(), before + 3);
  expect_prediction(*f);
  before = peer_->frames_filled();
  ASSERT_TRUE(cam.capture(5.0));
  EXPECT_EQ(peer_->frames_filled(), before + 1) << "no settling without a change";
}

TEST_F(SimCamera, IncompleteFrameIsRetriedNeverReturned) {
  AravisCameraConfig c;
  c.max_retries = 3;
  c.packet_resend = false;
  AravisCamera& cam = open(c);
  ASSERT_TRUE(cam.set_exposure(0.002));
  peer_->set_faults({.incomplete_frames = 1});
  auto f = cam.capture(10.0);
  ASSERT_TRUE(f) << f.error().what();
  EXPECT_EQ(cam.bad_buffers(), 1);
  EXPECT_EQ(cam.retried_captures(), 1);
  expect_prediction(*f);
}

TEST_F(SimCamera, PersistentlyIncompleteFramesAreAReportedRetryableError) {
  AravisCameraConfig c;
  c.max_retries = 2;
  c.packet_resend = false;
  AravisCamera& cam = open(c);
  ASSERT_TRUE(cam.set_exposure(0.002));
  peer_->set_faults({.incomplete_frames = 3});
  double w0 = wall_s();
  auto f = cam.capture(10.0);
  ASSERT_FALSE(f);
  EXPECT_TRUE(f.error().retryable());
  EXPECT_THAT(f.error().what(), ::testing::HasSubstr("no good frame after 3 attempts"));
  EXPECT_LT(wall_s() - w0, 10.0);
  EXPECT_EQ(cam.bad_buffers(), 3);
  // The camera works again afterwards.
  auto g = cam.capture(10.0);
  ASSERT_TRUE(g) << g.error().what();
  expect_prediction(*g);
}

TEST_F(SimCamera, CameraThatDisappearsIsAnErrorNotAHang) {
  AravisCameraConfig c;
  c.max_retries = 1;
  c.frame_timeout_s = 0.5;
  AravisCamera& cam = open(c);
  ASSERT_TRUE(cam.capture(5.0));
  peer_->stop();
  double w0 = wall_s();
  auto f = cam.capture(5.0);
  ASSERT_FALSE(f);
  // Aravis retries the unanswered trigger command for about 2.5 s.
  EXPECT_LT(wall_s() - w0, 6.0);
  EXPECT_FALSE(f.error().retryable());
  EXPECT_THAT(f.error().what(), ::testing::HasSubstr("camera is gone"));
  // Later commands fail at once instead of waiting for the same timeouts again.
  w0 = wall_s();
  auto e = cam.set_exposure(0.01);
  EXPECT_FALSE(e);
  EXPECT_LT(wall_s() - w0, 0.5);
}

TEST(SimCameraOpen, NoCameraAtTheAddressIsRetryable) {
  sim::GigePortLock port;  // no simulated camera of another test or process serves meanwhile
  AravisCameraConfig c;
  c.id = "127.0.0.1";
  double w0 = wall_s();
  auto r = AravisCamera::open(c);
  ASSERT_FALSE(r);
  EXPECT_TRUE(r.error().retryable());
  EXPECT_LT(wall_s() - w0, 10.0);
}

// ---- Aravis' own fake camera program ----

class AravisFakeProgram : public ::testing::Test {
 protected:
  void start(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> argv = {"arv-fake-gv-camera-0.8", "-i", "127.0.0.1"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    port_ = std::make_unique<sim::GigePortLock>();  // no other simulated camera meanwhile
    try {
      fake_ = std::make_unique<test::Process>(argv);
    } catch (const std::exception&) {
      FAIL() << "cannot start arv-fake-gv-camera-0.8 (Debian package aravis-tools; scripts/setup.sh installs it)";
    }
  }
  std::unique_ptr<AravisCamera> open(AravisCameraConfig c) {
    c.id = "127.0.0.1";
    // The program needs a moment to bind its port.
    for (int i = 0; i < 10; ++i) {
      auto r = AravisCamera::open(c);
      if (r) return std::move(*r);
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    return nullptr;
  }
  std::unique_ptr<sim::GigePortLock> port_;  // declared first: released after the program stopped
  std::unique_ptr<test::Process> fake_;
};

// The stock fake fills Mono8 with a ramp along x + y: on an intact frame every pixel
// equals its neighbour one step right and one step up.
bool diagonal_consistent(const dev::Frame& f) {
  for (int y = 0; y + 1 < f.pixels.height(); ++y)
    for (int x = 0; x + 1 < f.pixels.width(); ++x)
      if (f.pixels.at(x + 1, y) != f.pixels.at(x, y + 1)) return false;
  return true;
}

TEST_F(AravisFakeProgram, OlderFeatureNamesThroughAravisHelpers) {
  start();
  if (IsSkipped()) return;
  AravisCameraConfig c;
  c.pixel_format = PixelFormat::Mono8;
  c.packet_size = 1400;
  auto cam = open(c);
  ASSERT_TRUE(cam);
  // ExposureTimeAbs (us) behind set_exposure.
  auto e = cam->set_exposure(0.005);
  ASSERT_TRUE(e) << e.error().what();
  EXPECT_NEAR(*e, 0.005, 1e-9);
  // GainRaw only: dB needs gain_db_per_raw.
  EXPECT_TRUE(cam->set_gain_db(0.0));
  auto g = cam->set_gain_db(3.0);
  ASSERT_FALSE(g);
  EXPECT_THAT(g.error().what(), ::testing::HasSubstr("GainRaw"));
  auto f = cam->capture(5.0);
  ASSERT_TRUE(f) << f.error().what();
  EXPECT_EQ(f->pixels.width(), 512);
  EXPECT_EQ(f->pixels.height(), 512);
  EXPECT_TRUE(diagonal_consistent(*f));
  ASSERT_TRUE(cam->set_pixel_format(PixelFormat::Mono16));
  f = cam->capture(5.0);
  ASSERT_TRUE(f) << f.error().what();
  EXPECT_EQ(f->meta.format, PixelFormat::Mono16);
}

TEST_F(AravisFakeProgram, GainRawWithAConfiguredStep) {
  start();
  if (IsSkipped()) return;
  AravisCameraConfig c;
  c.pixel_format = PixelFormat::Mono8;
  c.gain_db_per_raw = 1.0;
  auto cam = open(c);
  ASSERT_TRUE(cam);
  auto g = cam->set_gain_db(3.2);
  ASSERT_TRUE(g) << g.error().what();
  EXPECT_DOUBLE_EQ(*g, 3.0);
}

TEST_F(AravisFakeProgram, LostPacketsAreRetriedOrReportedNeverReturned) {
  start({"-r", "5"});  // 0.5 % of the GVSP packets lost; the program never resends
  if (IsSkipped()) return;
  AravisCameraConfig c;
  c.pixel_format = PixelFormat::Mono8;
  c.packet_size = 1400;
  c.packet_resend = false;
  c.max_retries = 4;
  c.frame_retention_s = 0.05;
  auto cam = open(c);
  ASSERT_TRUE(cam);
  int good = 0, reported = 0;
  double w0 = wall_s();
  for (int i = 0; i < 10; ++i) {
    auto f = cam->capture(5.0);
    if (f) {
      ++good;
      EXPECT_TRUE(diagonal_consistent(*f)) << "a damaged frame was returned as good";
    } else {
      ++reported;
      EXPECT_TRUE(f.error().retryable());
    }
  }
  EXPECT_GT(cam->bad_buffers(), 0) << "no lost packets seen: the -r option had no effect";
  EXPECT_GT(good, 0);
  EXPECT_LT(wall_s() - w0, 60.0);
  RecordProperty("good", good);
  RecordProperty("reported", reported);
  RecordProperty("bad_buffers", cam->bad_buffers());
}

}  // namespace
}  // namespace paintlab
