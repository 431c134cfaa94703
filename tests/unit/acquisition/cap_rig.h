#pragma once
// The calibration capture's devices in memory (test::FakeCamera, FakeTable, FakeLight on a
// FakeClock) with a stage that records what it was asked to show, wired as the calibration
// steps capture through them (acq::CalibrationRig).
#include <string>
#include <vector>

#include "fake_rig.h"
#include "paintlab/acquisition/calibration_capture.h"

namespace paintlab::test {

constexpr double kCapBlackDn = 50.0;
constexpr double kCapFullDn = 65535.0;

// What the stage was asked, in order: "board 0/3", "mount the white reference sphere",
// "lens the lens cap", ...
class RecordingStage final : public acq::Stage {
 public:
  void show_board(int index, int count, const calib::BoardSpec&) override {
    calls.push_back("board " + std::to_string(index) + "/" + std::to_string(count));
  }
  void mount(acq::Target target) override { calls.push_back(std::string("mount ") + acq::to_string(target)); }
  void cover_lens(acq::LensView view) override { calls.push_back(std::string("lens ") + acq::to_string(view)); }
  void show_chart() override { calls.push_back("chart"); }
  std::vector<std::string> calls;
};

struct CapRig {
  explicit CapRig(const std::filesystem::path& captures) : shots({&table, &light, &camera, &clock}, captures, 0.0) {
    rig.camera = &camera;
    rig.light = &light;
    rig.table = &table;
    rig.clock = &clock;
    rig.stage = &stage;
    rig.shots = &shots;
    rig.linearizer = &linearizer;
    rig.gain_db = 3.0;
    rig.exposures_s = {0.00025, 0.328};
  }
  // `lit` DN/s above black with the LED on, `unlit` DN/s with it off.
  void scene(double lit, double unlit = 0.0) {
    camera.pixel = [lit, unlit](double t, bool on) { return kCapBlackDn + (on ? lit : unlit) * t; };
  }
  test::FakeClock clock;
  test::FakeTable table{clock};
  test::FakeLight light;
  test::FakeCamera camera{clock, light};
  RecordingStage stage;
  acq::Linearizer linearizer;
  acq::ShotCapture shots;
  acq::CalibrationRig rig;
};

}  // namespace paintlab::test
