// Device faults during a sweep, injected in the simulated peers while the real drivers
// (libmodbus, Aravis, the light driver) talk to them: transient faults are retried and the
// session completes; persistent ones stop the run safely (LED off, journal consistent,
// the reason names the device) and the session resumes to completion once the fault is
// gone.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "paintlab/acquisition/measurement.h"
#include "paintlab/acquisition/runner.h"
#include "paintlab/acquisition/session.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/world.h"
#include "paintlab/sim/peers/gige_camera.h"
#include "paintlab/sim/peers/sim_light.h"
#include "paintlab/sim/peers/sim_rig.h"
#include "paintlab/sim/peers/turntable_server.h"
#include "sim_devices.h"
#include "sim_rigs.h"
#include "test_util.h"

using namespace paintlab;
namespace fs = std::filesystem;

namespace {

constexpr int kPositions = 4;

class MeasureFaults : public ::testing::Test {
 protected:
  void SetUp() override {
    test::write_text(dir_ / "rig.toml", test::small_sim_rig(kPositions, 15.0, 3));
    rig_ = RigConfig::load(dir_ / "rig.toml");
    devices_ = test::open_sim_devices(rig_);
    ASSERT_TRUE(devices_.sim);
    camera_ = acq::prepare_camera(*devices_.camera, rig_);
  }

  acq::SessionDir create_session(const std::string& name) {
    acq::SessionManifest m;
    m.sample = "fault-test";
    m.rig_name = rig_.name;
    m.rig_file = rig_.file.string();
    m.angles_deg = rig_.plan.angles_deg();
    m.exposures_s = rig_.plan.exposures_s;
    m.settle_s = rig_.plan.settle_s;
    return acq::SessionDir::create(dir_ / name, std::move(m));
  }

  acq::RunSummary run(const acq::SessionDir& session, int max_retries = 3) {
    acq::RunnerOptions o;
    o.max_retries = max_retries;
    o.retry_backoff_s = 0.01;
    acq::BracketMerger merge(acq::HdrCalibration{}, dev::bit_depth(camera_.format));
    acq::Runner runner(session, {*devices_.turntable, *devices_.light, *devices_.camera, devices_.clock()},
                       merge.function(), o);
    std::atomic<bool> stop{false};
    return runner.run(stop);
  }

  int journal_lines(const acq::SessionDir& s) { return static_cast<int>(s.journal().read().size()); }

  test::TempDir dir_;
  RigConfig rig_;
  test::SimDevices devices_;
  acq::CameraPreparation camera_;
};

}  // namespace

TEST_F(MeasureFaults, ModbusTimeoutsAndDroppedConnectionsAreRetried) {
  acq::SessionDir s = create_session("timeouts");
  sim::ModbusFaults f;
  f.timeouts = 2;
  f.drops = 1;
  devices_.sim->turntable()->set_faults(f);
  acq::RunSummary r = run(s);
  EXPECT_TRUE(r.complete) << r.stop_reason;
  // The driver retried (reconnecting after the drop); every injected fault was hit.
  EXPECT_EQ(devices_.sim->turntable()->faulted_requests(), 3);
  EXPECT_EQ(journal_lines(s), kPositions);
  EXPECT_FALSE(devices_.sim->light()->emitting());
}

TEST_F(MeasureFaults, IncompleteFramesAreCapturedAgain) {
  acq::SessionDir s = create_session("frames");
  const std::uint64_t before = devices_.sim->camera()->frames_filled();
  devices_.sim->camera()->set_faults(sim::CameraFaults{2});
  acq::RunSummary r = run(s);
  EXPECT_TRUE(r.complete) << r.stop_reason;
  // Two frames were broken and captured again: two more frames than the plan needs.
  EXPECT_GE(devices_.sim->camera()->frames_filled() - before,
            static_cast<std::uint64_t>(r.frames) + 2);
  EXPECT_EQ(journal_lines(s), kPositions);
  // The merged images hold no trace of the broken frames: every one is journaled intact.
  EXPECT_TRUE(s.inspect().problems.empty());
}

TEST_F(MeasureFaults, PersistentModbusExceptionStopsSafelyAndTheSessionResumes) {
  acq::SessionDir s = create_session("exception");
  sim::ModbusFaults f;
  f.exception_code = 4;  // server device failure
  f.exceptions = 1000;
  devices_.sim->turntable()->set_faults(f);
  acq::RunSummary r = run(s, 2);
  EXPECT_FALSE(r.complete);
  EXPECT_TRUE(r.device_fault);
  EXPECT_NE(r.stop_reason.find("turntable"), std::string::npos) << r.stop_reason;
  EXPECT_NE(r.stop_reason.find("exception"), std::string::npos) << r.stop_reason;
  EXPECT_FALSE(devices_.sim->light()->emitting()) << "the LED must be off after a fault";
  acq::SessionState st = s.inspect();
  EXPECT_TRUE(st.problems.empty());
  EXPECT_EQ(static_cast<int>(st.todo.size()) + st.finished_count(), kPositions);

  devices_.sim->turntable()->set_faults(sim::ModbusFaults{});
  acq::SessionDir again = acq::SessionDir::open(dir_ / "exception");
  acq::RunSummary r2 = run(again);
  EXPECT_TRUE(r2.complete) << r2.stop_reason;
  EXPECT_EQ(journal_lines(again), kPositions);
}

TEST_F(MeasureFaults, ControllerAlarmStopsTheRunNamingTheAlarm) {
  acq::SessionDir s = create_session("alarm");
  sim::ModbusFaults f;
  f.alarm_code = 0x30;
  devices_.sim->turntable()->set_faults(f);
  acq::RunSummary r = run(s, 1);
  EXPECT_FALSE(r.complete);
  EXPECT_TRUE(r.device_fault);
  EXPECT_NE(r.stop_reason.find("alarm"), std::string::npos) << r.stop_reason;
  EXPECT_EQ(journal_lines(s), 0);
  EXPECT_FALSE(devices_.sim->light()->emitting());
}

TEST_F(MeasureFaults, StuckLedIsDetectedAndNothingIsJournaled) {
  acq::SessionDir s = create_session("stuck");
  devices_.sim->light()->set_stuck(true);  // off, and stays off whatever is commanded
  acq::RunSummary r = run(s, 1);
  EXPECT_FALSE(r.complete);
  EXPECT_TRUE(r.device_fault);
  EXPECT_NE(r.stop_reason.find("LED"), std::string::npos) << r.stop_reason;
  EXPECT_EQ(journal_lines(s), 0) << "a position measured without light must not be journaled";
}

TEST_F(MeasureFaults, CameraGoneStopsSafelyAndTheSessionResumesWhenItIsBack) {
  acq::SessionDir s = create_session("camera-gone");
  devices_.sim->camera()->stop();  // unplugged: no answers on 127.0.0.1:3956
  acq::RunSummary r = run(s, 1);
  EXPECT_FALSE(r.complete);
  EXPECT_TRUE(r.device_fault);
  EXPECT_NE(r.stop_reason.find("camera"), std::string::npos) << r.stop_reason;
  EXPECT_FALSE(devices_.sim->light()->emitting());
  EXPECT_EQ(journal_lines(s), 0);
  // Plugged back in: `paintlab measure --resume` is a new process with new connections.
  devices_ = test::SimDevices();  // first close everything (the port lock is per camera)
  devices_ = test::open_sim_devices(rig_);
  camera_ = acq::prepare_camera(*devices_.camera, rig_);
  acq::SessionDir again = acq::SessionDir::open(dir_ / "camera-gone");
  acq::RunSummary r2 = run(again);
  EXPECT_TRUE(r2.complete) << r2.stop_reason;
  EXPECT_EQ(journal_lines(again), kPositions);
}

// The merged radiance of a sweep against the simulator's truth at every sphere pixel:
// the merge of the frames the real drivers fetched must equal the mean rate the simulated
// sensor was driven with (signal + dark current, in the output's DN per second), within
// the variance the merge itself reports.
TEST_F(MeasureFaults, MergedRadianceMatchesTheSimulatorsTruthWithinTheNoise) {
  acq::SessionDir s = create_session("truth");
  sim::SimWorld& world = devices_.sim->world();
  const sim::SensorParams& p = world.config().sensor;
  const double shift = std::ldexp(1.0, dev::bit_depth(camera_.format) - p.adc_bits);
  acq::HdrOptions options;
  options.black_dn = p.black_level_dn * shift;
  options.saturation_dn = (p.adc_max_dn() - 1) * shift;
  const double gain = world.sensor().gain_dn_per_e(camera_.gain_db) * shift;
  options.noise = {p.read_noise_e * gain, gain, "sim sensor truth"};
  options.floor_dn = 3.0 * p.read_noise_e * gain;
  acq::HdrMerger merger(acq::HdrCalibration{}, options, rig_.geometry.image_width_px, rig_.geometry.image_height_px, 1,
                        dev::bit_depth(camera_.format));
  acq::MergeFn merge = [&](const std::vector<dev::Frame>& frames) {
    std::vector<calib::StackFrame> stack;
    for (const auto& f : frames) stack.push_back({&f.pixels, f.meta.exposure_s});
    return merger.merge(stack).image;
  };
  acq::RunnerOptions o;
  acq::Runner runner(s, {*devices_.turntable, *devices_.light, *devices_.camera, devices_.clock()}, merge, o);
  std::atomic<bool> stop{false};
  ASSERT_TRUE(runner.run(stop).complete);

  const ImageF coverage = world.sphere_coverage();
  const std::vector<std::uint32_t>& hot = world.sensor().hot_pixels();
  std::vector<double> z;
  for (const acq::JournalEntry& e : s.journal().read()) {
    const ExrImage img = read_exr(s.dir() / e.file);
    // The world rendered at the angle the table really reached (the encoder's read-back).
    const ImageF radiance = world.render_at(e.angle_read_deg, true);
    const ImageF& y = img.plane("Y");
    const ImageF& var = img.plane("var.Y");
    const ImageF& valid = img.plane("valid");
    for (int py = 0; py < y.height(); ++py)
      for (int px = 0; px < y.width(); ++px) {
        const std::size_t i = static_cast<std::size_t>(py) * y.width() + px;
        if (coverage.data()[i] < 0.999f || valid.data()[i] < 0.5f) continue;
        if (std::binary_search(hot.begin(), hot.end(), static_cast<std::uint32_t>(i))) continue;
        const double truth = (radiance.data()[i] * world.sensor().electrons_per_s_per_radiance(px, py) +
                              world.sensor().dark_e_per_s(px, py)) * gain;
        z.push_back((y.data()[i] - truth) / std::sqrt(var.data()[i]));
      }
  }
  ASSERT_GT(z.size(), 5000u);
  double mean = 0, sq = 0;
  for (double v : z) mean += v;
  mean /= static_cast<double>(z.size());
  for (double v : z) sq += (v - mean) * (v - mean);
  const double sd = std::sqrt(sq / static_cast<double>(z.size() - 1));
  std::sort(z.begin(), z.end());
  std::cout << z.size() << " sphere pixels: z = (merged - truth) / sqrt(var): mean " << mean << ", sd " << sd
            << ", median " << z[z.size() / 2] << "\n";
  EXPECT_LT(std::abs(mean), 0.1);
  EXPECT_GT(sd, 0.8);
  EXPECT_LT(sd, 1.25);
}
