#pragma once
// What the simulated camera sees, by name: the painted sphere, the white reference sphere,
// a chessboard or ChArUco board, a colour chart lit by the LED's white, a uniform field
// (diffuser) or a dark field (lens cap), as
// scene radiance in W sr^-1 m^-2 with a one-line description. `paintlab sim render` writes
// it; calibration stages show it to the simulated camera (SimRig::show).
#include <string>
#include <string_view>

#include "paintlab/core/image.h"
#include "paintlab/core/image_io.h"
#include "paintlab/sim/scenes.h"
#include "paintlab/sim/sensor.h"
#include "paintlab/sim/world.h"

namespace paintlab::sim {

enum class SceneKind { Sphere, White, Chessboard, Charuco, Flat, Dark, ColourChart };
// "sphere", "white", "chessboard", "charuco", "flat", "dark", "colour-chart"
const char* to_string(SceneKind k);
// DataError naming `where` and every scene for another name.
SceneKind scene_kind_from_string(const std::string& s, std::string_view where = {});

struct SceneRequest {
  SceneKind kind = SceneKind::Sphere;
  double angle_deg = 0.0;   // table angle (sphere, white)
  bool led_on = true;       // sphere, white
  double albedo = 0.99;     // the white reference's
  int view = 0;             // which generated board pose (chessboard, charuco): 0, 1, ...
  int views = 0;            // boards: poses generated for this many views (0: view + 1)
  Chessboard chessboard{};  // the chessboard's corners and squares
  ColourChart chart{};      // colour-chart: the patches and their colours (the caller gives them)
  // The exposure the lighting is set for: a board's white and the uniform field reach half
  // the full well at the image centre in this time.
  double exposure_s = 0.01;
  int channels = 1;         // 1 (the monochrome camera's mix) or 3 (linear camera RGB)
  bool sparkle = true;      // sphere: flake glints
  std::string paint_name{}; // sphere: named in the description when given
  int threads = 0;          // 0: all cores
  void check() const;       // UsageError naming the field
};

struct SceneRender {
  ImageF radiance;          // channels as requested
  std::string description;  // e.g. "white reference sphere (albedo 0.99) at table angle 30 deg"
};

// The scene's radiance as an EXR (channel Y, or R, G, B) with what it shows and the rig file
// in its header (paintlab.content, paintlab.scene, paintlab.rig).
ExrImage scene_exr(const SceneRender& scene, const std::string& rig_file);

// One raw frame of the scene through `world`'s sensor, 16-bit MSB-aligned, and how many of
// its values are clipped at the ADC's top.
struct SceneFrame {
  Image<std::uint16_t> raw;
  long long saturated = 0;
};
SceneFrame expose_scene(SimWorld& world, const SceneRender& scene, const ExposureSettings& settings, int threads = 0);

// The scene in `world` (the sphere scene shows the world's paint). Boards come from
// chessboard_poses/charuco_poses with the world's seed: view v is pose v of `views` (of v + 1
// when views is 0).
SceneRender render_scene(SimWorld& world, const SceneRequest& request);

}  // namespace paintlab::sim
