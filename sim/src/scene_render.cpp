#include "paintlab/sim/scene_render.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/scenes.h"

namespace paintlab::sim {

namespace {

constexpr EnumNames<SceneKind, 7> kSceneNames{{
    {SceneKind::Sphere, "sphere"},
    {SceneKind::White, "white"},
    {SceneKind::Chessboard, "chessboard"},
    {SceneKind::Charuco, "charuco"},
    {SceneKind::Flat, "flat"},
    {SceneKind::Dark, "dark"},
    {SceneKind::ColourChart, "colour-chart"},
}};

// A board at view q.view (pose v of q.views, or of v + 1, with the world's seed), lit so that its white
// reaches half the full well at the image centre in q.exposure_s.
template <class Board, class Poses, class Render>
ImageF render_board(SimWorld& world, const SceneRequest& q, const Board& board, Poses poses_of, Render render) {
  const auto poses = poses_of(world.camera(), board, q.views > 0 ? q.views : q.view + 1, world.config().seed);
  PlaneLighting light;
  light.irradiance_w_m2 = world.irradiance_for_fill(0.5, q.exposure_s, board.white_albedo);
  return render(world.camera(), board, poses.at(static_cast<std::size_t>(q.view)), light, 16, q.channels, q.threads);
}

}  // namespace

const char* to_string(SceneKind k) { return enum_name(kSceneNames, k); }

SceneKind scene_kind_from_string(const std::string& s, std::string_view where) {
  return enum_from_name(kSceneNames, s, "scene", where);
}

void SceneRequest::check() const {
  if (!std::isfinite(angle_deg)) throw UsageError(fmt::format("scene angle_deg {}: must be finite", angle_deg));
  if (!(albedo >= 0 && albedo <= 1)) throw UsageError(fmt::format("scene albedo {}: must be in [0, 1]", albedo));
  if (view < 0 || view > 99) throw UsageError(fmt::format("scene view {}: must be in 0..99", view));
  if (views != 0 && (views <= view || views > 100))
    throw UsageError(fmt::format("scene views {}: must be 0 or in {}..100 (more than view {})", views, view + 1, view));
  if (chessboard.cols < 2 || chessboard.rows < 2 || !(chessboard.square_m > 0))
    throw UsageError(fmt::format("scene chessboard {}x{} of {} m squares: needs at least 2x2 inner corners and a "
                                 "square > 0",
                                 chessboard.cols, chessboard.rows, chessboard.square_m));
  if (!(exposure_s > 0) || !std::isfinite(exposure_s))
    throw UsageError(fmt::format("scene exposure_s {}: must be > 0", exposure_s));
  if (channels != 1 && channels != 3) throw UsageError(fmt::format("scene channels {}: must be 1 or 3", channels));
  if (threads < 0) throw UsageError(fmt::format("scene threads {}: must be >= 0 (0 = all cores)", threads));
}

SceneRender render_scene(SimWorld& world, const SceneRequest& q) {
  q.check();
  RenderOptions opt;
  opt.mono = q.channels == 1;
  opt.sparkle = q.sparkle;
  opt.threads = q.threads;
  SceneRender out;
  switch (q.kind) {
    case SceneKind::Sphere:
      out.radiance = world.render_at(q.angle_deg, q.led_on, opt);
      out.description = fmt::format("sphere{} at table angle {:g} deg{}",
                                    q.paint_name.empty() ? "" : " painted '" + q.paint_name + "'", q.angle_deg,
                                    q.led_on ? "" : ", LED off");
      break;
    case SceneKind::White:
      out.radiance = world.render_with(reference_paint(q.albedo), q.angle_deg, q.led_on, opt);
      out.description = fmt::format("white reference sphere (albedo {:g}) at table angle {:g} deg{}", q.albedo,
                                    q.angle_deg, q.led_on ? "" : ", LED off");
      break;
    case SceneKind::Chessboard: {
      const Chessboard& board = q.chessboard;
      out.radiance = render_board(world, q, board, chessboard_poses, render_chessboard);
      out.description = fmt::format("{}x{} chessboard of {:g} mm squares, view {}", board.cols, board.rows,
                                    board.square_m * 1e3, q.view);
      break;
    }
    case SceneKind::Charuco: {
      const CharucoBoard board;
      out.radiance = render_board(world, q, board, charuco_poses, render_charuco);
      out.description = fmt::format("{}x{} ChArUco board of {:g} mm squares, {:g} mm DICT_6X6_250 markers, view {}",
                                    board.squares_x, board.squares_y, board.square_m * 1e3, board.marker_m * 1e3,
                                    q.view);
      break;
    }
    case SceneKind::Flat: {
      const double level = world.radiance_for_fill(0.5, q.exposure_s);
      out.radiance = uniform_field(world.camera(), level, q.channels);
      out.description = fmt::format("uniform field of {:.4g} W sr^-1 m^-2 (half the full well at the centre)", level);
      break;
    }
    case SceneKind::Dark:
      out.radiance = dark_field(world.camera(), q.channels);
      out.description = "dark frame";
      break;
    case SceneKind::ColourChart: {
      // Lit by the LED's white so that the brightest patch channel reaches half the full well.
      const ColourChart& chart = q.chart;
      chart.check();
      const auto poses =
          colour_chart_poses(world.camera(), chart, q.views > 0 ? q.views : q.view + 1, world.config().seed);
      PlaneLighting light;
      light.irradiance_w_m2 = world.irradiance_for_fill(0.5, q.exposure_s, chart.max_albedo());
      light.colour = world.config().led.color;
      ImageF rgb = render_colour_chart(world.camera(), chart, poses.at(static_cast<std::size_t>(q.view)), light, 16,
                                       q.threads);
      if (q.channels == 1) {  // a monochrome camera: w . RGB
        const auto& w = world.config().camera.mono_weights;
        ImageF mono(rgb.width(), rgb.height(), 1);
        for (int y = 0; y < rgb.height(); ++y)
          for (int x = 0; x < rgb.width(); ++x)
            mono.at(x, y) = static_cast<float>(w[0] * rgb.at(x, y, 0) + w[1] * rgb.at(x, y, 1) + w[2] * rgb.at(x, y, 2));
        rgb = std::move(mono);
      }
      out.radiance = std::move(rgb);
      out.description = fmt::format("{}x{} colour chart of {:g} mm patches, view {}", chart.cols, chart.rows,
                                    chart.patch_m * 1e3, q.view);
      break;
    }
  }
  return out;
}

ExrImage scene_exr(const SceneRender& scene, const std::string& rig_file) {
  const ImageF& r = scene.radiance;
  ExrImage exr;
  if (r.channels() == 1) {
    exr.add("Y", r);
  } else {
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) {
      ImageF plane(r.width(), r.height(), 1);
      for (std::size_t i = 0; i < plane.size(); ++i) plane.data()[i] = r.data()[i * 3 + c];
      exr.add(names[c], std::move(plane));
    }
  }
  exr.attributes["paintlab.content"] = "simulated scene radiance, W sr^-1 m^-2, linear camera RGB";
  exr.attributes["paintlab.scene"] = scene.description;
  exr.attributes["paintlab.rig"] = rig_file;
  return exr;
}

SceneFrame expose_scene(SimWorld& world, const SceneRender& scene, const ExposureSettings& settings, int threads) {
  ExposureSettings e = settings;
  e.output_bits = 16;
  SceneFrame f;
  f.raw = world.sensor().expose(scene.radiance, e, threads);
  const auto& sensor = world.config().sensor;
  const auto top = static_cast<std::uint16_t>(static_cast<unsigned>(sensor.adc_max_dn()) << (16 - sensor.adc_bits));
  f.saturated = std::count(f.raw.values().begin(), f.raw.values().end(), top);
  return f;
}

}  // namespace paintlab::sim
