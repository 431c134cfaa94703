#include "calibrate_support.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <iostream>

#include "cli.h"
#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/calibration/colour.h"
#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/procedure.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/response.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/image_io.h"
#include "paintlab/devices/device_config.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/peers/sim_rig.h"
#include "paintlab/sim/scene_render.h"
#include "paintlab/sim/scenes.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

// A technician at the keyboard: says what to put where and waits for Enter.
class ConsoleStage final : public acq::Stage {
 public:
  void show_board(int index, int count, const calib::BoardSpec& board) override {
    prompt(fmt::format("Hold the {}x{} chessboard in view {} of {} (whole board visible, a different tilt each time) "
                       "and press Enter",
                       board.cols, board.rows, index + 1, count));
  }
  void mount(Target target) override {
    if (target == current_) return;
    prompt(fmt::format("Put {} on the holder and press Enter", acq::to_string(target)));
    current_ = target;
  }
  void show_chart() override {
    prompt("Put the ColorChecker in front of the camera, facing it, evenly lit by the LED without glare, its black "
           "border in view, and press Enter");
    current_ = Target::Sample;  // whatever was on the holder is hidden or moved: ask again next time
  }
  void cover_lens(acq::LensView view) override {
    switch (view) {
      case acq::LensView::Scene:
        prompt("Take the lens cap or diffuser off the lens and press Enter");
        break;
      case acq::LensView::Capped:
        prompt("Put the cap on the lens (dark frames) and press Enter");
        break;
      case acq::LensView::Diffuser:
        prompt("Put the diffuser over the lens, or a uniformly lit white target filling the view (flat field), and "
               "press Enter");
        break;
    }
  }

 private:
  static void prompt(const std::string& text) {
    say(text);
    std::string line;
    if (!std::getline(std::cin, line))
      throw UsageError("--capture on a real rig needs a technician at the keyboard (standard input is closed)");
  }
  Target current_ = Target::Sample;
};

// The simulator plays the technician: it swaps the sphere's paint and shows chessboards
// to the simulated camera (which still reaches us through the GigE Vision driver).
class SimStage final : public acq::Stage {
 public:
  SimStage(sim::SimRig& rig, double albedo) : rig_(rig), albedo_(albedo > 0 ? albedo : 0.99), sample_(rig.world().paint()) {}

  void show_board(int index, int count, const calib::BoardSpec& board) override {
    sim::SceneRequest q;  // lit so that white reaches half the full well in 10 ms at the image centre
    q.kind = sim::SceneKind::Chessboard;
    q.chessboard.cols = board.cols;
    q.chessboard.rows = board.rows;
    q.chessboard.square_m = board.square_m;
    q.view = index;
    q.views = count;
    rig_.show(std::make_shared<ImageF>(sim::render_scene(rig_.world(), q).radiance));
    board_shown_ = true;
  }

  void mount(Target target) override {
    if (board_shown_) {
      rig_.show_world();
      board_shown_ = false;
    }
    switch (target) {
      case Target::Sample:
        rig_.world().set_paint(sample_);
        break;
      case Target::WhiteReference:
        rig_.world().set_paint(sim::reference_paint(albedo_));
        break;
      case Target::GlossySphere:
        rig_.world().set_paint(sim::glossy_black_sphere_paint());
        break;
    }
  }
  // The simulated camera's frames show a dark field or a uniform field through the
  // simulated sensor.
  void cover_lens(acq::LensView view) override {
    if (view == acq::LensView::Scene) return rig_.show_world();
    // Bright enough that the image centre reaches half the full well in 10 ms.
    sim::SceneRequest q;
    q.kind = view == acq::LensView::Capped ? sim::SceneKind::Dark : sim::SceneKind::Flat;
    q.exposure_s = 0.01;
    rig_.show(std::make_shared<ImageF>(sim::render_scene(rig_.world(), q).radiance));
  }
  // The ColorChecker's reference colours (the argyll-ref file) rendered on the rig, lit by the LED's white.
  void show_chart() override {
    sim::SceneRequest q;
    q.kind = sim::SceneKind::ColourChart;
    q.channels = 3;
    q.chart.patch_rgb = calib::ChartReference::load(calib::kColorCheckerReference).srgb_reflectances();
    rig_.show(std::make_shared<ImageF>(sim::render_scene(rig_.world(), q).radiance));
    board_shown_ = true;
  }
  double known_albedo() const override { return albedo_; }

 private:
  sim::SimRig& rig_;
  double albedo_;
  sim::SimPaint sample_;
  bool board_shown_ = false;
};

}  // namespace

acq::HdrCalibration load_radiometry(const RigConfig& rig) {
  return acq::HdrCalibration::of(calib::RigCalibration::load(rig));
}

void check_step_outputs(fit::OutputGuard guard, const std::string& rig_file, const std::vector<std::string>& steps,
                        const fs::path& out) {
  guard.input("--rig", rig_file);
  const fs::path dir = out.empty() ? load_rig(rig_file).calibration_dir : fs::path();
  for (const std::string& step : steps) {
    const fs::path json = out.empty() ? dir / calib::procedure_step(step).file : out;
    std::vector<fs::path> written = {json};
    if (step == "dark" || step == "flat") written.push_back(fs::path(json).replace_extension(".exr"));
    for (const fs::path& w : written) {
      OutputSpec spec(out.empty() ? "--rig" : "--out", w);
      if (out.empty()) spec.beside = rig_file;
      else if (w != out) spec.beside = out;
      spec.create_parents = true;
      guard.output(spec);
    }
  }
  guard.check();
}

Json device_serials(RigDevices& d, const RigConfig& rig) {
  // The camera's serial number; the turntable and LED have none over their protocols, so
  // their kind and address stand for them (not for simulated peers, whose ports change).
  Json j = Json::object();
  if (d.camera) j["camera"] = d.camera->serial();
  if (d.turntable && rig.turntable.kind != "sim") j["turntable"] = d.turntable->id();
  if (d.light && rig.light.kind != "sim") j["light"] = d.light->id();
  return j;
}

CalibSession open_calib_session(const RigConfig& rig, double albedo) {
  CalibSession s;
  s.rig = rig;
  s.devices = std::make_unique<RigDevices>(open_rig_devices(rig));
  if (s.devices->sim)
    s.stage = std::make_unique<SimStage>(*s.devices->sim, albedo);
  else
    s.stage = std::make_unique<ConsoleStage>();
  s.linearizer.set_calibration(load_radiometry(rig));
  s.serials = device_serials(*s.devices, rig);
  s.bit_depth = dev::bit_depth(value_or_throw(s.camera().pixel_format()));
  value_or_throw(s.camera().set_gain_db(rig.plan.gain_db));
  RigDevices& d = *s.devices;
  s.shots = std::make_unique<acq::ShotCapture>(
      acq::ShotCapture::Devices{d.turntable.get(), d.light.get(), d.camera.get(), d.clock, d.filter_wheel.get(),
                                rig.filter_wheel ? dev::filter_wheel_config(*rig.filter_wheel).channel_slot
                                                 : std::array<int, 3>{1, 2, 3}},
      rig.calibration_dir / "captures", rig.plan.settle_s);
  return s;
}

acq::CalibrationRig CalibSession::capture_rig() {
  acq::CalibrationRig r;
  r.camera = devices->camera.get();
  r.light = devices->light.get();
  r.table = devices->turntable.get();
  r.clock = devices->clock;
  r.stage = stage.get();
  r.shots = shots.get();
  r.linearizer = &linearizer;
  r.gain_db = rig.plan.gain_db;
  r.exposures_s = rig.plan.exposures_s;
  r.settle_s = rig.plan.settle_s;
  return r;
}

}  // namespace paintlab::app
