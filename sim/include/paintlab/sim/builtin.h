#pragma once
// What the simulator carries built in, so that `paintlab demo` and a simulated rig run from
// anywhere: the simulated rig (examples/rig-sim.toml, embedded at build time) and the paint
// a simulated sample wears unless told otherwise (paints/silver-metallic.toml).
#include <string>

#include "paintlab/brdf/paint.h"

namespace paintlab::sim {

// The text of examples/rig-sim.toml as built.
const char* builtin_rig_toml();
// The text of paints/silver-metallic.toml as built, and the paint it describes.
const char* builtin_paint_toml();
brdf::PaintSpec builtin_paint();

// The paint a simulated sample wears: a paint file's (its spec and text) or, without a file,
// the built-in one. UsageError naming `option` for a MERL table (it has no analytic form to
// simulate, sparkle and all).
struct SimulatedPaint {
  brdf::PaintSpec spec;
  std::string toml_text;
};
SimulatedPaint simulated_paint(const std::string& file, const std::string& option);

// The camera of the demo's rig: the built-in rig's monochrome Mono16 camera, a colour camera
// in its place (BayerRG16 behind a channel mix unlike sRGB, with gains of its own: docs/
// simulator.md), or the monochrome camera behind a simulated filter wheel (R, G, B filters in
// slots 1, 2, 3 on a pty pair). The colour ones measure under a warm LED, which the colour
// calibration has to undo.
enum class DemoCamera { Mono, Bayer, Wheel };
const char* to_string(DemoCamera c);  // "mono", "bayer", "wheel"
DemoCamera demo_camera_from_string(const std::string& s, const std::string& option);  // UsageError naming option

// The rig `paintlab demo` writes: the built-in rig with its calibration folder "calib"
// beside the rig file and the given camera; with `quick`, half the resolution (pixels twice
// as large, the simulated intrinsics and blur halved, pixel centres kept), light every 10 deg
// and 8 exposures. Numbers rounded to 6 significant digits, a comment line first.
std::string demo_rig_toml(bool quick, DemoCamera camera = DemoCamera::Mono);

}  // namespace paintlab::sim
