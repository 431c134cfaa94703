#include "measure_support.h"

#include <fmt/format.h>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/error.h"
#include "paintlab/sim/builtin.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/peers/sim_rig.h"
#include "cli.h"

namespace fs = std::filesystem;

namespace paintlab::app {

void apply_sim_paint(RigDevices& devices, const Json& paint_json, const fs::path& where) {
  brdf::PaintSpec spec = brdf::paint_from_json(paint_json, (where / "session.json").string() + ": options.sim_paint");
  devices.sim->world().set_paint(sim::sim_paint(spec));
}

}  // namespace paintlab::app
