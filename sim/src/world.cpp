#include "paintlab/sim/world.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <fmt/format.h>

#include "paintlab/core/error.h"
#include "paintlab/sim/flakes.h"
#include "parallel.h"

namespace paintlab::sim {

namespace {

using Vec3f = Eigen::Vector3f;
using brdf::Rgb;
constexpr double kInfD = std::numeric_limits<double>::infinity();
constexpr double kEps = 1e-9;

enum PixelKind : std::uint8_t { kBackground = 0, kInterior = 1, kEdge = 2 };

// Nearest t > 0 where o + t d (d unit) meets the sphere.
bool hit_sphere(const Vec3& o, const Vec3& d, const Vec3& c, double r, double* t) {
  Vec3 oc = o - c;
  double b = oc.dot(d);
  double disc = b * b - (oc.squaredNorm() - r * r);
  if (disc < 0) return false;
  double s = std::sqrt(disc);
  if (-b - s > kEps) {
    *t = -b - s;
    return true;
  }
  if (-b + s > kEps) {
    *t = -b + s;
    return true;
  }
  return false;
}

// Whether the segment from p to q passes through the sphere.
bool segment_hits_sphere(const Vec3& p, const Vec3& q, const Vec3& c, double r) {
  Vec3 d = q - p;
  double len = d.norm();
  d /= len;
  Vec3 oc = p - c;
  double b = oc.dot(d);
  double disc = b * b - (oc.squaredNorm() - r * r);
  if (disc <= 0) return false;
  double s = std::sqrt(disc);
  return -b + s > 1e-7 && -b - s < len;
}

// A capped cylinder from `a` along unit `axis` for `length`.
struct Cylinder {
  Vec3 a;
  Vec3 axis;
  double length = 0;
  double radius = 0;
};

bool hit_cylinder(const Vec3& o, const Vec3& d, const Cylinder& cy, double* t_out, Vec3* n_out) {
  if (cy.radius <= 0 || cy.length <= 0) return false;
  Vec3 oc = o - cy.a;
  double dz = d.dot(cy.axis), oz = oc.dot(cy.axis);
  Vec3 dm = d - dz * cy.axis, om = oc - oz * cy.axis;
  double best = kInfD;
  Vec3 bn = Vec3::Zero();
  double A = dm.squaredNorm();
  if (A > 1e-18) {
    double B = 2.0 * dm.dot(om), C = om.squaredNorm() - cy.radius * cy.radius;
    double disc = B * B - 4.0 * A * C;
    if (disc >= 0) {
      double s = std::sqrt(disc);
      for (double t : {(-B - s) / (2.0 * A), (-B + s) / (2.0 * A)}) {
        double z = oz + t * dz;
        if (t > kEps && z >= 0 && z <= cy.length) {
          best = t;
          bn = (om + t * dm) / cy.radius;
          break;
        }
      }
    }
  }
  if (std::abs(dz) > 1e-18) {
    for (double zc : {0.0, cy.length}) {
      double t = (zc - oz) / dz;
      if (t > kEps && t < best && (om + t * dm).squaredNorm() <= cy.radius * cy.radius) {
        best = t;
        bn = zc == 0.0 ? Vec3(-cy.axis) : cy.axis;
      }
    }
  }
  if (best == kInfD) return false;
  *t_out = best;
  *n_out = bn;
  return true;
}

struct Light {
  Vec3 pos;
  Vec3 axis;
  double i0 = 0;
  Rgb color = Rgb::Ones();

  void set_exponent(double n) {
    exponent_ = n;
    double twice = 2.0 * n;
    twice_exponent_ = (twice == std::round(twice) && twice <= 32.0) ? static_cast<int>(twice) : -1;
  }
  // cos^n of the angle off the LED axis; half-integer n without pow().
  double profile(double cos_off_axis) const {
    if (exponent_ == 0) return 1.0;
    if (cos_off_axis <= 0) return 0.0;
    if (twice_exponent_ < 0) return std::pow(cos_off_axis, exponent_);
    double v = (twice_exponent_ & 1) ? std::sqrt(cos_off_axis) : 1.0;
    for (int k = 0; k < twice_exponent_ / 2; ++k) v *= cos_off_axis;
    return v;
  }

 private:
  double exponent_ = 1;
  int twice_exponent_ = 2;
};

}  // namespace

// ---------------------------------------------------------------------------------------
// Static geometry: everything that does not change with the table angle, computed once.
struct SimWorld::Scene {
  int w = 0, h = 0;
  Vec3 cam_centre;
  Mat3 rig_from_cam;
  Vec3 c;
  double r = 0;
  const CameraModel* camera = nullptr;

  std::vector<std::uint8_t> kind;    // per pixel
  std::vector<std::int32_t> slot;    // per pixel: interior index, or edge index
  std::vector<float> depth;          // per pixel: distance to the first static surface
  // Interior sphere pixels.
  std::vector<std::uint32_t> interior_pixel;
  std::vector<Vec3f> interior_q;     // hit point minus sphere centre
  std::vector<float> interior_area;  // footprint on the sphere, m^2
  // Silhouette pixels: coverage and up to edge_shading_samples^2 shaded hits each.
  struct Edge {
    std::uint32_t pixel;
    float coverage;
    std::uint32_t count;
  };
  std::vector<Edge> edges;
  int edge_slots = 1;
  std::vector<Vec3f> edge_q;
  // Background (felt) per pixel: first static non-sphere surface.
  struct Bg {
    Vec3f p;
    Vec3f n;
    float albedo;
  };
  std::vector<Bg> bg;
  // Normalised-plane extent of the image (for culling the arm).
  Vec2 norm_min, norm_max;
  // Felt surroundings.
  double table_z = 0, table_radius = 0, backdrop_x = 0, felt = 0, post_radius = 0;
  Cylinder pedestal;

  Vec3 ray(int x, int y, double fx, double fy) const {
    Vec2 xn = camera->grid_point(x, y, fx, fy);
    return (rig_from_cam * Vec3(xn.x(), xn.y(), 1.0)).normalized();
  }

  // The nearest felt surface of the static surroundings along a ray.
  bool hit_background(const Vec3& o, const Vec3& d, double* t, Vec3* n) const {
    double best = kInfD;
    Vec3 bn;
    if (d.z() < 0 && o.z() > table_z) {
      double tt = (table_z - o.z()) / d.z();
      Vec3 p = o + tt * d;
      if (p.head<2>().squaredNorm() <= table_radius * table_radius && tt < best) {
        best = tt;
        bn = Vec3::UnitZ();
      }
    }
    if (d.x() < 0 && o.x() > backdrop_x) {
      double tt = (backdrop_x - o.x()) / d.x();
      if (tt > kEps && tt < best) {
        best = tt;
        bn = Vec3::UnitX();
      }
    }
    double tc;
    Vec3 nc;
    if (hit_cylinder(o, d, pedestal, &tc, &nc) && tc < best) {
      best = tc;
      bn = nc;
    }
    if (best == kInfD) return false;
    *t = best;
    *n = bn;
    return true;
  }
};

struct SimWorld::PaintState {
  SimPaint paint;
  bool flakes = false;
  std::unique_ptr<FlakeCapTable> cap;
  double cos_lifetime = 1.0;
  double flakes_per_m2 = 0.0;
  double floor = 0.1;
  bool coloured = false;
  double shift_rad_per_rad = 0.0;      // interference flakes' hue turn
  // A flake of an interior pixel: its normal (x 32767) and its tint (FlakeTint: chroma x 255,
  // hue in 65536 steps of a turn).
  struct FlakeRec {
    std::array<std::int16_t, 3> normal;
    std::uint8_t chroma;
    std::uint8_t interference;
    std::uint16_t hue;
  };
  std::vector<std::uint32_t> offsets;  // per interior pixel + 1
  std::vector<FlakeRec> normals;
};

SimWorld::SimWorld(const SimConfig& config)
    : config_(config), clock_(config.clock_speed), scene_(std::make_unique<Scene>()) {
  config_.check();
  camera_ = std::make_unique<CameraModel>(config_.camera);
  const auto& cam = *camera_;
  Vec3 c_cam = cam.cam_from_rig() * config_.sphere.centre_rig_m;
  if (c_cam.z() <= config_.sphere.radius_m)
    throw DataError("simulator: the sphere is not in front of the camera (centre at z = " + std::to_string(c_cam.z()) +
                    " m in the camera frame)");
  Vec2 c_px = cam.project(c_cam);
  if (c_px.x() < 0 || c_px.y() < 0 || c_px.x() > cam.width() - 1 || c_px.y() > cam.height() - 1)
    throw DataError("simulator: the sphere centre projects to pixel (" + std::to_string(c_px.x()) + ", " +
                    std::to_string(c_px.y()) + "), outside the image");
  sensor_ = std::make_unique<Sensor>(cam, config_.sensor, config_.seed);

  // --- static scene ---
  Scene& s = *scene_;
  s.camera = camera_.get();
  s.w = cam.width();
  s.h = cam.height();
  s.cam_centre = cam.centre_rig();
  s.rig_from_cam = cam.rig_from_cam().matrix();
  s.c = config_.sphere.centre_rig_m;
  s.r = config_.sphere.radius_m;
  const auto& sc = config_.scene;
  s.table_z = -sc.table_depth_m;
  s.table_radius = sc.table_radius_m;
  s.backdrop_x = -sc.backdrop_distance_m;
  s.felt = sc.felt_albedo;
  s.post_radius = sc.arm_post_radius_m;
  s.pedestal = {Vec3(s.c.x(), s.c.y(), s.table_z), Vec3::UnitZ(), s.c.z() - 0.5 * s.r - s.table_z, sc.pedestal_radius_m};

  const auto& grid = cam.corner_grid();
  s.norm_min = Vec2(kInfD, kInfD);
  s.norm_max = -s.norm_min;
  for (const Vec2& g : grid) {
    s.norm_min = s.norm_min.cwiseMin(g);
    s.norm_max = s.norm_max.cwiseMax(g);
  }

  const std::size_t n = static_cast<std::size_t>(s.w) * s.h;
  s.kind.assign(n, kBackground);
  s.slot.assign(n, -1);
  s.depth.assign(n, std::numeric_limits<float>::infinity());
  s.bg.assign(n, Scene::Bg{Vec3f::Zero(), Vec3f::Zero(), 0.0f});
  detail::parallel_rows(s.h, 0, [&](int y) {
    for (int x = 0; x < s.w; ++x) {
      std::size_t i = static_cast<std::size_t>(y) * s.w + x;
      Vec3 d = s.ray(x, y, 0.5, 0.5);
      Vec3 oc = s.c - s.cam_centre;
      double tca = oc.dot(d);
      double rho = std::sqrt(std::max(0.0, oc.squaredNorm() - tca * tca));
      // Pixel size at the sphere's distance (the diagonal: a generous margin).
      std::size_t gw = static_cast<std::size_t>(s.w) + 1;
      double diag = (grid[(y + 1) * gw + x + 1] - grid[y * gw + x]).norm() * oc.norm();
      if (tca > 0 && rho < s.r - diag) s.kind[i] = kInterior;
      else if (tca > 0 && rho < s.r + diag) s.kind[i] = kEdge;
      double t;
      Vec3 nb;
      if (s.kind[i] != kInterior && s.hit_background(s.cam_centre, d, &t, &nb)) {
        Vec3 p = s.cam_centre + t * d;
        s.bg[i] = {p.cast<float>(), nb.cast<float>(), static_cast<float>(s.felt)};
        s.depth[i] = static_cast<float>(t);
      }
      double ts;
      if (s.kind[i] != kBackground && hit_sphere(s.cam_centre, d, s.c, s.r, &ts)) s.depth[i] = static_cast<float>(ts);
    }
  });
  for (std::size_t i = 0; i < n; ++i) {
    if (s.kind[i] == kInterior) {
      s.slot[i] = static_cast<std::int32_t>(s.interior_pixel.size());
      s.interior_pixel.push_back(static_cast<std::uint32_t>(i));
    } else if (s.kind[i] == kEdge) {
      s.slot[i] = static_cast<std::int32_t>(s.edges.size());
      s.edges.push_back({static_cast<std::uint32_t>(i), 0.0f, 0});
    }
  }
  s.interior_q.resize(s.interior_pixel.size());
  s.interior_area.resize(s.interior_pixel.size());
  detail::parallel_rows(static_cast<int>(s.interior_pixel.size()), 0, [&](int j) {
    std::uint32_t i = s.interior_pixel[static_cast<std::size_t>(j)];
    int x = static_cast<int>(i % static_cast<std::uint32_t>(s.w)), y = static_cast<int>(i / static_cast<std::uint32_t>(s.w));
    double t = 0;
    Vec3 d = s.ray(x, y, 0.5, 0.5);
    hit_sphere(s.cam_centre, d, s.c, s.r, &t);
    s.interior_q[j] = (s.cam_centre + t * d - s.c).cast<float>();
    std::array<Vec3, 4> p;
    const double corner[4][2] = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
    bool all = true;
    for (int k = 0; k < 4; ++k) {
      Vec3 dk = s.ray(x, y, corner[k][0], corner[k][1]);
      double tk;
      all = all && hit_sphere(s.cam_centre, dk, s.c, s.r, &tk);
      p[k] = s.cam_centre + tk * dk;
    }
    // Area of the footprint quad from its diagonals.
    s.interior_area[j] = all ? static_cast<float>(0.5 * (p[3] - p[0]).cross(p[2] - p[1]).norm()) : 0.0f;
  });
  const int S = config_.render.edge_samples, T = config_.render.edge_shading_samples;
  s.edge_slots = T * T;
  s.edge_q.assign(s.edges.size() * static_cast<std::size_t>(s.edge_slots), Vec3f::Zero());
  detail::parallel_rows(static_cast<int>(s.edges.size()), 0, [&](int e) {
    Scene::Edge& edge = s.edges[static_cast<std::size_t>(e)];
    int x = static_cast<int>(edge.pixel % static_cast<std::uint32_t>(s.w));
    int y = static_cast<int>(edge.pixel / static_cast<std::uint32_t>(s.w));
    int hits = 0;
    double best_rho = kInfD;
    Vec3 best_d;
    Vec3 oc = s.c - s.cam_centre;
    for (int b = 0; b < S; ++b)
      for (int a = 0; a < S; ++a) {
        Vec3 d = s.ray(x, y, (a + 0.5) / S, (b + 0.5) / S);
        double tca = oc.dot(d);
        double rho2 = oc.squaredNorm() - tca * tca;
        if (tca > 0 && rho2 < s.r * s.r) {
          ++hits;
          if (rho2 < best_rho) {
            best_rho = rho2;
            best_d = d;
          }
        }
      }
    edge.coverage = static_cast<float>(hits) / static_cast<float>(S * S);
    std::uint32_t count = 0;
    Vec3f* q = &s.edge_q[static_cast<std::size_t>(e) * s.edge_slots];
    for (int b = 0; b < T; ++b)
      for (int a = 0; a < T; ++a) {
        Vec3 d = s.ray(x, y, (a + 0.5) / T, (b + 0.5) / T);
        double t;
        if (hit_sphere(s.cam_centre, d, s.c, s.r, &t)) q[count++] = (s.cam_centre + t * d - s.c).cast<float>();
      }
    if (count == 0 && hits > 0) {
      double t;
      if (hit_sphere(s.cam_centre, best_d, s.c, s.r, &t)) q[count++] = (s.cam_centre + t * best_d - s.c).cast<float>();
    }
    edge.count = count;
  });

  set_paint({std::make_shared<brdf::Lambertian>(Rgb::Constant(0.5)), std::nullopt});
}

SimWorld::~SimWorld() = default;

Vec3 SimWorld::led_position_rig(double table_angle_deg) const {
  const auto& l = config_.led;
  double a = deg_to_rad(table_angle_deg + l.zero_deg);
  return {l.arm_radius_m * std::cos(a), l.arm_radius_m * std::sin(a), l.arm_height_m};
}

Vec3 SimWorld::led_axis_rig(double table_angle_deg) const {
  return (config_.led.aim_rig_m - led_position_rig(table_angle_deg)).normalized();
}

double SimWorld::led_profile(double off_axis_rad) const {
  Light l;
  l.set_exponent(config_.led.profile_exponent);
  return l.profile(std::cos(off_axis_rad));
}

Rgb SimWorld::led_radiant_intensity(double table_angle_deg, const Vec3& point_rig) const {
  Vec3 dir = (point_rig - led_position_rig(table_angle_deg)).normalized();
  double prof = led_profile(angle_between(dir, led_axis_rig(table_angle_deg)));
  const auto& col = config_.led.color;
  return Rgb(col[0], col[1], col[2]) * (config_.led.intensity_w_sr * prof);
}

double SimWorld::reference_footprint_m2() const {
  double d = (camera_->centre_rig() - config_.sphere.centre_rig_m).norm();
  return d * d / (config_.camera.fx_px * config_.camera.fy_px);
}

std::shared_ptr<const SimWorld::PaintState> SimWorld::make_paint_state(SimPaint paint) const {
  if (!paint.brdf) throw DataError("simulator: the sphere's paint has no BRDF");
  auto st = std::make_shared<PaintState>();
  st->floor = config_.render.sparkle_floor;
  if (paint.sparkle) {
    const Sparkle& sp = *paint.sparkle;
    if (!(sp.density > 0) || !std::isfinite(sp.density)) throw DataError("simulator: flake density must be > 0");
    if (!(sp.roughness > 0 && sp.roughness < 1)) throw DataError("simulator: flake roughness must be in (0, 1)");
    if (!(sp.lifetime_deg > 0 && sp.lifetime_deg <= 45)) throw DataError("simulator: flake lifetime must be in (0, 45] deg");
    if (!sp.flake_part) throw DataError("simulator: sparkle needs the part of the BRDF the flakes carry");
    const Scene& s = *scene_;
    st->flakes = true;
    st->cap = std::make_unique<FlakeCapTable>(sp.roughness, deg_to_rad(sp.lifetime_deg), 1024);
    st->cos_lifetime = std::cos(deg_to_rad(sp.lifetime_deg));
    st->flakes_per_m2 = sp.density / reference_footprint_m2();
    double expected_total = st->flakes_per_m2 * 2.0 * kPi * s.r * s.r;
    if (expected_total > 1.5e8)
      throw DataError(fmt::format("simulator: a flake density of {:.3g} per pixel footprint means about {:.3g} "
                                  "visible flakes, more than the renderer keeps (1.5e8)",
                                  sp.density, expected_total));
    FlakeField field(s.r, st->flakes_per_m2, sp.roughness, config_.flake_field_seed());
    st->coloured = sp.colour.any();
    st->shift_rad_per_rad = sp.colour.interference_shift_deg;  // deg per deg = rad per rad
    std::vector<std::pair<std::uint32_t, PaintState::FlakeRec>> assigned;
    const CameraModel& cam = *camera_;
    const Rigid3& cfr = cam.cam_from_rig();
    // Only cells and flakes that land in the image; points are first checked in the
    // undistorted plane (outside the image the distortion polynomial may fold back).
    auto in_view = [&](const Vec3& p_rig, double margin_norm) {
      Vec3 pc = cfr * p_rig;
      if (pc.z() <= 0) return false;
      Vec2 xn(pc.x() / pc.z(), pc.y() / pc.z());
      return xn.x() >= s.norm_min.x() - margin_norm && xn.y() >= s.norm_min.y() - margin_norm &&
             xn.x() <= s.norm_max.x() + margin_norm && xn.y() <= s.norm_max.y() + margin_norm;
    };
    const double depth = (cfr * s.c).z();
    auto keep_cell = [&](const Vec3& centre_dir, double radius_rad) {
      return in_view(s.c + s.r * centre_dir, 1.5 * radius_rad * s.r / (depth - s.r));
    };
    field.for_each_visible(s.cam_centre - s.c, [&](const Flake& f) {
      if (!in_view(s.c + s.r * f.position_dir, 0.0)) return;
      Vec2 px = cam.project_rig(s.c + s.r * f.position_dir);
      double fx = std::floor(px.x() + 0.5), fy = std::floor(px.y() + 0.5);
      if (fx < 0 || fy < 0 || fx >= s.w || fy >= s.h) return;
      std::size_t i = static_cast<std::size_t>(fy) * s.w + static_cast<std::size_t>(fx);
      if (s.kind[i] != kInterior) return;
      PaintState::FlakeRec q{};
      for (int k = 0; k < 3; ++k) q.normal[k] = static_cast<std::int16_t>(std::lround(f.normal[k] * 32767.0));
      if (st->coloured) {
        const FlakeTint t = draw_flake_tint(f.colour_bits, sp.colour);
        q.chroma = static_cast<std::uint8_t>(std::lround(t.chroma * 255.0));
        q.interference = t.interference ? 1 : 0;
        q.hue = static_cast<std::uint16_t>(std::lround(t.hue_rad / (2.0 * kPi) * 65536.0) & 0xFFFF);
      }
      assigned.emplace_back(static_cast<std::uint32_t>(s.slot[i]), q);
    }, keep_cell);
    st->offsets.assign(s.interior_pixel.size() + 1, 0);
    for (const auto& a : assigned) ++st->offsets[a.first + 1];
    for (std::size_t j = 1; j < st->offsets.size(); ++j) st->offsets[j] += st->offsets[j - 1];
    st->normals.resize(assigned.size());
    std::vector<std::uint32_t> fill(st->offsets.begin(), st->offsets.end() - 1);
    for (const auto& a : assigned) st->normals[fill[a.first]++] = a.second;
  }
  st->paint = std::move(paint);
  return st;
}

double SimWorld::radiance_for_fill(double fill, double exposure_s) const {
  const double g = sensor_->electrons_per_s_per_radiance(camera_->width() / 2, camera_->height() / 2);
  return fill * config_.sensor.full_well_e / (g * exposure_s);
}

double SimWorld::irradiance_for_fill(double fill, double exposure_s, double albedo) const {
  return radiance_for_fill(fill, exposure_s) * std::numbers::pi / albedo;
}

void SimWorld::set_paint(SimPaint paint) {
  auto st = make_paint_state(std::move(paint));
  std::lock_guard lock(paint_mutex_);
  paint_ = std::move(st);
}

SimPaint SimWorld::paint() const {
  std::lock_guard lock(paint_mutex_);
  return paint_->paint;
}

ImageF SimWorld::render(const RenderOptions& options) const {
  return render_at(table_angle_deg(), led_on(), options);
}

ImageF SimWorld::render_at(double table_angle_deg, bool led_on, const RenderOptions& options) const {
  std::shared_ptr<const PaintState> st;
  {
    std::lock_guard lock(paint_mutex_);
    st = paint_;
  }
  return render_impl(*st, table_angle_deg, led_on, options);
}

ImageF SimWorld::render_with(const SimPaint& paint, double table_angle_deg, bool led_on,
                             const RenderOptions& options) const {
  auto st = make_paint_state(paint);
  return render_impl(*st, table_angle_deg, led_on, options);
}

ImageF SimWorld::sphere_coverage() const {
  const Scene& s = *scene_;
  ImageF out(s.w, s.h, 1, 0.0f);
  for (std::uint32_t p : s.interior_pixel) out.data()[p] = 1.0f;
  for (const auto& e : s.edges) out.data()[e.pixel] = e.coverage;
  return out;
}

Image<std::uint16_t> SimWorld::capture(const ExposureSettings& exposure, const RenderOptions& options) {
  return sensor_->expose(render(options), exposure, options.threads);
}

ImageF SimWorld::render_impl(const PaintState& st, double angle_deg, bool led_on, const RenderOptions& opt) const {
  const Scene& s = *scene_;
  const int ch = opt.mono ? 1 : 3;
  ImageF out(s.w, s.h, ch, 0.0f);
  if (!led_on) return out;

  Light light;
  light.pos = led_position_rig(angle_deg);
  light.axis = led_axis_rig(angle_deg);
  light.i0 = config_.led.intensity_w_sr;
  light.set_exponent(config_.led.profile_exponent);
  light.color = Rgb(config_.led.color[0], config_.led.color[1], config_.led.color[2]);
  const auto& mw = config_.camera.mono_weights;
  const Rgb mono(mw[0], mw[1], mw[2]);
  const brdf::Brdf& f_paint = *st.paint.brdf;
  const bool sparkle = opt.sparkle && st.flakes;
  const brdf::Brdf* f_flakes = sparkle ? st.paint.sparkle->flake_part.get() : nullptr;
  // With the rest of the BRDF given separately: f = steady + s flakes (one evaluation of
  // each part instead of the whole BRDF plus the flake part).
  const brdf::Brdf* f_steady = sparkle ? st.paint.sparkle->steady_part.get() : nullptr;

  auto write_to = [&](ImageF& img, std::size_t i, const Rgb& v) {
    if (ch == 1) {
      img.data()[i] = static_cast<float>((v * mono).sum());
    } else {
      for (int k = 0; k < 3; ++k) img.data()[i * 3 + k] = static_cast<float>(v[k]);
    }
  };
  auto write = [&](std::size_t i, const Rgb& v) { write_to(out, i, v); };
  // Pixel integration of the sphere's interior needs the image without glints (below).
  const int n_sub = config_.render.interior_samples;
  std::optional<ImageF> smooth_img;
  if (n_sub > 1 && sparkle) smooth_img.emplace(s.w, s.h, ch, 0.0f);
  ImageF* smooth = smooth_img ? &*smooth_img : nullptr;

  // Radiance at sphere point q (relative to the centre) in two parts: `smooth`, the paint's
  // BRDF (the flakes at their average), and `flakes`, the part the flakes carry, so that a
  // pixel whose flakes glint by a factor k shows smooth + (k - 1) flakes.
  struct Parts {
    Rgb smooth = Rgb::Zero();
    Rgb flakes = Rgb::Zero();
  };
  // The light and view directions in the shading frame at sphere point q and the
  // irradiance there; false where the point is unlit or unseen.
  struct Local {
    Vec3 wi, wo;
    Rgb e;
  };
  auto local_at = [&](const Vec3& q, Local* l) -> bool {
    Vec3 p = s.c + q;
    Vec3 n = q / s.r;
    Vec3 wo = (s.cam_centre - p).normalized();
    Vec3 d = light.pos - p;
    double r2 = d.squaredNorm();
    Vec3 wi = d / std::sqrt(r2);
    double cos_i = n.dot(wi);
    if (cos_i <= 0 || n.dot(wo) <= 0) return false;
    double prof = light.profile(-wi.dot(light.axis));
    if (prof <= 0) return false;
    Mat3 frame = frame_from_normal(n);
    l->wi = frame.transpose() * wi;
    l->wo = frame.transpose() * wo;
    l->e = light.color * (light.i0 * prof * cos_i / r2);
    return true;
  };
  auto shade_parts = [&](const Vec3& q) -> Parts {
    Local l;
    if (!local_at(q, &l)) return {};
    if (!f_flakes) return {Rgb(f_paint.eval(l.wi, l.wo) * l.e), Rgb::Zero()};
    const Rgb fl = f_flakes->eval(l.wi, l.wo);
    const Rgb smooth = f_steady ? Rgb(f_steady->eval(l.wi, l.wo) + fl) : Rgb(f_paint.eval(l.wi, l.wo));
    return {Rgb(smooth * l.e), Rgb(fl * l.e)};
  };
  // The sparkle factor (K + eps) / (lambda + eps) of interior pixel j: K of its flakes lit
  // for the half vector at sphere point q, lambda the count expected there. With coloured
  // flakes K is the sum of the lit flakes' tints (per channel; E[tint] = 1).
  auto flake_factor = [&](const Vec3& q, std::size_t j) -> Rgb {
    Vec3 p = s.c + q;
    Vec3 n = q / s.r;
    const Vec3 to_light = (light.pos - p).normalized();
    Vec3 hv = (to_light + (s.cam_centre - p).normalized()).normalized();
    double lambda = st.flakes_per_m2 * s.interior_area[j] * (*st.cap)(n.dot(hv));
    Eigen::Vector3f hf = hv.cast<float>() * (1.0f / 32767.0f);
    float cos_l = static_cast<float>(st.cos_lifetime);
    Rgb k = Rgb::Zero();
    // A lit flake's normal is within the lifetime of h: the light meets it at about the
    // angle between the light and h.
    const double incidence = std::acos(std::clamp(to_light.dot(hv), -1.0, 1.0));
    for (std::uint32_t a = st.offsets[j]; a < st.offsets[j + 1]; ++a) {
      const auto& nf = st.normals[a];
      if (hf.x() * nf.normal[0] + hf.y() * nf.normal[1] + hf.z() * nf.normal[2] < cos_l) continue;
      if (nf.chroma == 0) {
        k += Rgb::Ones();
        continue;
      }
      double hue = nf.hue * (2.0 * kPi / 65536.0);
      if (nf.interference) hue += st.shift_rad_per_rad * incidence;
      k += flake_tint_rgb(nf.chroma / 255.0, hue).array();
    }
    return (k + st.floor) / (lambda + st.floor);
  };
  // The whole BRDF (the flakes at their average), for the silhouette's samples: one
  // evaluation where shade_parts needs two under sparkle.
  auto shade_sphere = [&](const Vec3& q) -> Rgb {
    Local l;
    if (!local_at(q, &l)) return Rgb::Zero();
    return Rgb(f_paint.eval(l.wi, l.wo) * l.e);
  };

  // Felt (single precision: it only needs to be right to ~1e-6 relative).
  const Vec3f led_f = light.pos.cast<float>(), axis_f = light.axis.cast<float>(), c_f = s.c.cast<float>();
  const float r2_sphere = static_cast<float>(s.r * s.r);
  auto shade_bg = [&](std::size_t i) -> Rgb {
    const Scene::Bg& b = s.bg[i];
    if (b.albedo <= 0) return Rgb::Zero();
    Vec3f d = led_f - b.p;
    float r2 = d.squaredNorm();
    float inv = 1.0f / std::sqrt(r2);
    float cos_i = b.n.dot(d) * inv;
    if (cos_i <= 0) return Rgb::Zero();
    double prof = light.profile(-axis_f.dot(d) * inv);
    if (prof <= 0) return Rgb::Zero();
    // The sphere's shadow: does the segment to the LED pass through it?
    Vec3f oc = b.p - c_f;
    float bb = oc.dot(d) * inv;
    float disc = bb * bb - (oc.squaredNorm() - r2_sphere);
    if (disc > 0) {
      float sq = std::sqrt(disc);
      if (-bb + sq > 1e-6f && -bb - sq < r2 * inv) return Rgb::Zero();
    }
    return light.color * (b.albedo / kPi * light.i0 * prof * cos_i / r2);
  };

  detail::parallel_rows(s.h, opt.threads, [&](int y) {
    for (int x = 0; x < s.w; ++x) {
      std::size_t i = static_cast<std::size_t>(y) * s.w + x;
      switch (s.kind[i]) {
        case kInterior: {
          auto j = static_cast<std::size_t>(s.slot[i]);
          const Vec3 q = s.interior_q[j].cast<double>();
          const Parts parts = shade_parts(q);
          if (sparkle) {
            const Rgb factor = flake_factor(q, j);
            write(i, parts.smooth + Rgb((factor.array() - 1.0) * parts.flakes.array()));
          } else {
            write(i, parts.smooth);
          }
          if (smooth) write_to(*smooth, i, parts.smooth);
          break;
        }
        case kEdge: {
          const Scene::Edge& e = s.edges[static_cast<std::size_t>(s.slot[i])];
          Rgb sum = Rgb::Zero();
          const Vec3f* q = &s.edge_q[static_cast<std::size_t>(s.slot[i]) * s.edge_slots];
          for (std::uint32_t k = 0; k < e.count; ++k) sum += shade_sphere(q[k].cast<double>());
          Rgb v = (e.count ? Rgb(sum / e.count) : Rgb(Rgb::Zero())) * e.coverage + shade_bg(i) * (1.0 - e.coverage);
          write(i, v);
          break;
        }
        default:
          write(i, shade_bg(i));
      }
    }
  });

  // A pixel integrates the radiance over its area. The pass above shades each interior
  // pixel at its centre, which is the pixel's mean to second order:
  // mean = centre + (f_xx + f_yy) / 24 px^2. Where that term (from the discrete Laplacian of
  // the smooth image: the glints are whole-pixel events) is above interior_tolerance of the
  // value, the pixel is integrated on an n x n grid: a highlight a few pixels across, the
  // terminator. The flakes' factor stays the one counted at the centre.
  if (n_sub > 1) {
    const ImageF& sm = smooth ? *smooth : out;
    const float* v = sm.data();
    const double tol = config_.render.interior_tolerance;
    float peak = 0.0f;
    for (std::uint32_t p : s.interior_pixel)
      for (int c = 0; c < ch; ++c) peak = std::max(peak, v[static_cast<std::size_t>(p) * ch + c]);
    const double floor_abs = 1e-3 * tol * peak;
    std::vector<std::vector<std::uint32_t>> rows(static_cast<std::size_t>(s.h));
    detail::parallel_rows(s.h - 2, opt.threads, [&](int row) {
      const int y = row + 1;
      auto& list = rows[static_cast<std::size_t>(y)];
      for (int x = 1; x + 1 < s.w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * s.w + x;
        if (s.kind[i] != kInterior) continue;
        const std::size_t w = static_cast<std::size_t>(s.w);
        for (int c = 0; c < ch; ++c) {
          auto at = [&](std::size_t k) { return static_cast<double>(v[k * ch + c]); };
          const double lap = at(i - 1) + at(i + 1) + at(i - w) + at(i + w) - 4.0 * at(i);
          if (std::abs(lap) / 24.0 > tol * std::abs(at(i)) + floor_abs) {
            list.push_back(static_cast<std::uint32_t>(i));
            break;
          }
        }
      }
    });
    std::vector<std::uint32_t> todo;
    for (const auto& r : rows) todo.insert(todo.end(), r.begin(), r.end());
    const double inv = 1.0 / n_sub;
    detail::parallel_rows(static_cast<int>(todo.size()), opt.threads, [&](int t) {
      const std::uint32_t i = todo[static_cast<std::size_t>(t)];
      const int x = static_cast<int>(i % static_cast<std::uint32_t>(s.w));
      const int y = static_cast<int>(i / static_cast<std::uint32_t>(s.w));
      const auto j = static_cast<std::size_t>(s.slot[i]);
      const Rgb factor = sparkle ? flake_factor(s.interior_q[j].cast<double>(), j) : Rgb(Rgb::Ones());
      Parts sum;
      int hits = 0;
      for (int b = 0; b < n_sub; ++b)
        for (int a = 0; a < n_sub; ++a) {
          const Vec3 d = s.ray(x, y, (a + 0.5) * inv, (b + 0.5) * inv);
          double tt;
          if (!hit_sphere(s.cam_centre, d, s.c, s.r, &tt)) continue;
          const Parts pa = shade_parts(s.cam_centre + tt * d - s.c);
          sum.smooth += pa.smooth;
          sum.flakes += pa.flakes;
          ++hits;
        }
      if (hits > 0) write(i, Rgb((sum.smooth.array() + (factor.array() - 1.0) * sum.flakes.array()) / hits));
    });
  }

  // The LED arm (a vertical post up to the LED and a bar along the table top) moves with
  // the table: test the pixels of its bounding box.
  const double post_r = s.post_radius;
  if (post_r > 0) {
    Vec3 radial(light.pos.x(), light.pos.y(), 0.0);
    double arm_r = radial.norm();
    radial /= arm_r;
    Cylinder post{Vec3(light.pos.x(), light.pos.y(), s.table_z), Vec3::UnitZ(), light.pos.z() - s.table_z, post_r};
    double bar_start = std::min(s.table_radius, arm_r);
    Cylinder bar{Vec3(0, 0, s.table_z + post_r) + bar_start * radial, radial, arm_r - bar_start, post_r};
    // Pixel rectangle that holds the image of an axis-aligned rig box (empty: x0 > x1).
    struct Box {
      int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
      bool contains(int x, int y) const { return x >= x0 && x <= x1 && y >= y0 && y <= y1; }
    };
    const Rigid3& cfr = cam_from_rig();
    auto pixel_box = [&](const Vec3& lo, const Vec3& hi) {
      Box b;
      Vec2 nlo(kInfD, kInfD), nhi(-kInfD, -kInfD);
      for (int k = 0; k < 8; ++k) {
        Vec3 pc = cfr * Vec3((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z());
        if (pc.z() <= 1e-6) return Box{0, 0, s.w - 1, s.h - 1};  // reaches behind the camera: test everything
        Vec2 xn(pc.x() / pc.z(), pc.y() / pc.z());
        nlo = nlo.cwiseMin(xn);
        nhi = nhi.cwiseMax(xn);
      }
      if (nhi.x() < s.norm_min.x() || nlo.x() > s.norm_max.x() || nhi.y() < s.norm_min.y() || nlo.y() > s.norm_max.y())
        return b;
      // Clip in the undistorted plane (where the distortion is monotone), then map to pixels.
      nlo = nlo.cwiseMax(s.norm_min);
      nhi = nhi.cwiseMin(s.norm_max);
      double px0 = kInfD, py0 = kInfD, px1 = -kInfD, py1 = -kInfD;
      for (int k = 0; k < 9; ++k) {
        Vec2 xn(nlo.x() + (nhi.x() - nlo.x()) * (k % 3) / 2.0, nlo.y() + (nhi.y() - nlo.y()) * (k / 3) / 2.0);
        Vec2 px = camera_->project(Vec3(xn.x(), xn.y(), 1.0));
        px0 = std::min(px0, px.x());
        py0 = std::min(py0, px.y());
        px1 = std::max(px1, px.x());
        py1 = std::max(py1, px.y());
      }
      b.x0 = std::max(0, static_cast<int>(std::floor(px0)) - 3);
      b.y0 = std::max(0, static_cast<int>(std::floor(py0)) - 3);
      b.x1 = std::min(s.w - 1, static_cast<int>(std::ceil(px1)) + 3);
      b.y1 = std::min(s.h - 1, static_cast<int>(std::ceil(py1)) + 3);
      return b;
    };
    const Vec3 pr = Vec3::Constant(post_r);
    const Vec3 post_top(post.a.x(), post.a.y(), light.pos.z());
    const Vec3 bar_end = bar.a + bar.length * bar.axis;
    const Box post_box = pixel_box(post.a.cwiseMin(post_top) - pr, post.a.cwiseMax(post_top) + pr);
    const Box bar_box = pixel_box(bar.a.cwiseMin(bar_end) - pr, bar.a.cwiseMax(bar_end) + pr);
    // Shades pixel (x, y) if the post (and/or the bar) is the nearest surface there.
    auto arm_pixel = [&](int x, int y, bool test_post, bool test_bar) {
      std::size_t i = static_cast<std::size_t>(y) * s.w + x;
      Vec3 d = s.ray(x, y, 0.5, 0.5);
      double best = s.depth[i], t;
      Vec3 n, bn;
      bool hit = false;
      if (test_post && hit_cylinder(s.cam_centre, d, post, &t, &n) && t < best) {
        best = t;
        bn = n;
        hit = true;
      }
      if (test_bar && hit_cylinder(s.cam_centre, d, bar, &t, &n) && t < best) {
        best = t;
        bn = n;
        hit = true;
      }
      if (!hit) return;
      Vec3 p = s.cam_centre + best * d;
      Vec3 dl = light.pos - p;
      double r2 = dl.squaredNorm();
      Vec3 wi = dl / std::sqrt(r2);
      double cos_i = bn.dot(wi);
      double prof = light.profile(-wi.dot(light.axis));
      Rgb v = Rgb::Zero();
      if (cos_i > 0 && prof > 0 && !segment_hits_sphere(p, light.pos, s.c, s.r))
        v = light.color * (s.felt / kPi * light.i0 * prof * cos_i / r2);
      write(i, v);
    };
    if (post_box.x0 <= post_box.x1 && post_box.y0 <= post_box.y1)
      detail::parallel_rows(post_box.y1 - post_box.y0 + 1, opt.threads, [&](int row) {
        int y = post_box.y0 + row;
        for (int x = post_box.x0; x <= post_box.x1; ++x) arm_pixel(x, y, true, bar_box.contains(x, y));
      });
    if (bar_box.x0 <= bar_box.x1 && bar_box.y0 <= bar_box.y1)
      detail::parallel_rows(bar_box.y1 - bar_box.y0 + 1, opt.threads, [&](int row) {
        int y = bar_box.y0 + row;
        for (int x = bar_box.x0; x <= bar_box.x1; ++x)
          if (!post_box.contains(x, y)) arm_pixel(x, y, false, true);
      });
  }
  camera_->blur(out, opt.threads);
  return out;
}

}  // namespace paintlab::sim
