#include "paintlab/sim/peers/sim_rig.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>

#include "paintlab/devices/device_config.h"

namespace paintlab::sim {

// The last radiance image: a bracket at one table angle renders once.
struct SimRig::Cache {
  std::mutex mutex;
  bool valid = false;
  double angle_deg = 0.0;
  bool led_on = false;
  bool rgb = false;  // rendered in scene RGB (for a colour-filter array) or mono
  const void* paint = nullptr;
  ImageF radiance;
};

SimRig::SimRig(const RigConfig& rig, SimRigOptions options) : cache_(std::make_shared<Cache>()) {
  world_ = std::make_unique<SimWorld>(SimConfig::from_rig(rig));
  clock_ = options.clock ? options.clock : &world_->clock();
  if (options.turntable) {
    dev::ModbusTurntableConfig tc = dev::turntable_config(rig.turntable);
    TurntableServerOptions o;
    o.map = tc.map;
    o.scale = tc.scale;
    o.wrap = tc.wrap;
    o.unit_id = tc.unit_id;
    o.default_accel_deg_s2 = tc.accel_deg_s2;
    turntable_ = std::make_unique<TurntableServer>(o, *clock_);
    if (options.modbus_tcp) modbus_port_ = turntable_->start_tcp(options.modbus_port);
    if (options.modbus_rtu) rtu_path_ = turntable_->start_rtu();
  }
  if (options.light) {
    SimLightOptions lo;
    if (rig.light.kind == "sim") lo.max_on_s = dev::sim_light_config(rig.light).max_on_s;
    SimWorld* w = world_.get();
    light_ = std::make_unique<SimLight>(lo, *clock_, [w](bool on) { w->set_led_on(on); });
    world_->set_led_on(false);
  }
  if (options.filter_wheel && rig.filter_wheel && rig.filter_wheel->kind == "sim") {
    const dev::FilterWheelSetup setup = dev::filter_wheel_config(*rig.filter_wheel);
    SimFilterWheelOptions wo;
    wo.slots = setup.sim_slots;
    wo.move_s_per_slot = setup.serial.move_s_per_slot;  // rig.toml's move_ms_per_slot
    wheel_ = std::make_unique<SimFilterWheel>(wo, *clock_);
    const auto& w = world_->config().camera.mono_weights;
    const auto& f = world_->config().filters;
    wheel_mix_.assign(static_cast<std::size_t>(setup.sim_slots), w);  // empty slots pass everything
    const std::array<double, 3>* filter[3] = {&f.red, &f.green, &f.blue};
    for (std::size_t c = 0; c < 3; ++c)
      for (std::size_t k = 0; k < 3; ++k)
        wheel_mix_[static_cast<std::size_t>(setup.channel_slot[c] - 1)][k] = w[k] * (*filter[c])[k];
  }
  if (options.camera) {
    dev::AravisCameraConfig cc = dev::camera_config(rig.camera, rig.geometry);
    GigeCameraOptions go;
    go.width = world_->camera().width();
    go.height = world_->camera().height();
    go.readout_s = world_->config().sensor.readout_s;
    go.format = cc.pixel_format;
    go.black_level = world_->config().sensor.black_level_dn;
    camera_ = std::make_unique<GigeCamera>(go, *clock_, world_source());
    camera_->start();
  }
}

SimRig::~SimRig() {
  // The camera first: its fill callback uses the world, the table and the light.
  camera_.reset();
  wheel_.reset();
  turntable_.reset();
  light_.reset();
}

namespace {

// A grey scene (one channel) as scene RGB.
ImageF grey_to_rgb(const ImageF& grey) {
  ImageF rgb(grey.width(), grey.height(), 3);
  const float* in = grey.data();
  float* out = rgb.data();
  for (std::size_t i = 0; i < grey.size(); ++i) out[3 * i] = out[3 * i + 1] = out[3 * i + 2] = in[i];
  return rgb;
}

// One frame of `radiance` through the simulated sensor at the request's exposure, gain and
// depth; the camera's BlackLevel moves the sensor's black level (in the output's units). A
// Bayer format samples the scene's RGB through the colour-filter array (a grey scene given
// as one channel is taken as equal RGB).
void expose_frame(SimWorld& world, const ImageF& radiance, const FrameRequest& r, std::uint16_t* out,
                  const std::array<double, 3>* filter = nullptr) {
  ExposureSettings es;
  es.exposure_s = r.exposure_s;
  es.gain_db = r.gain_db;
  const int bits = dev::bit_depth(r.format);
  es.output_bits = bits;
  const dev::CfaPattern cfa = dev::cfa_pattern(r.format);
  if (cfa != dev::CfaPattern::None) {
    es.cfa = std::array<int, 4>{dev::cfa_colour(cfa, 0, 0), dev::cfa_colour(cfa, 1, 0), dev::cfa_colour(cfa, 0, 1),
                                dev::cfa_colour(cfa, 1, 1)};
  } else if (filter) {
    es.mono_mix = *filter;  // a monochrome sensor behind the wheel's filter
  } else if (radiance.channels() == 3) {
    es.mono_mix = world.config().camera.mono_weights;  // a monochrome sensor sees w . RGB
  }
  const bool needs_rgb = (cfa != dev::CfaPattern::None || filter) && radiance.channels() == 1;
  const Image<std::uint16_t> raw = world.sensor().expose(needs_rgb ? grey_to_rgb(radiance) : radiance, es);
  const auto& sp = world.config().sensor;
  const double offset = (r.black_level - sp.black_level_dn) * std::ldexp(1.0, bits - sp.adc_bits);
  const double max = std::ldexp(1.0, bits) - 1.0;
  const int cw = std::min(r.width, raw.width()), ch = std::min(r.height, raw.height());
  std::fill(out, out + static_cast<std::size_t>(r.width) * r.height, std::uint16_t{0});
  for (int y = 0; y < ch; ++y)
    for (int x = 0; x < cw; ++x)
      out[static_cast<std::size_t>(y) * r.width + x] =
          static_cast<std::uint16_t>(std::clamp(std::round(raw.at(x, y) + offset), 0.0, max));
}

}  // namespace

FrameSource SimRig::static_source(std::shared_ptr<const ImageF> radiance) {
  SimWorld* w = world_.get();
  const SimFilterWheel* wheel = wheel_.get();
  const std::vector<std::array<double, 3>>* mix = &wheel_mix_;
  return [w, radiance, wheel, mix](const FrameRequest& r, std::uint16_t* out) {
    // A grey target seen through the filter in front of the lens.
    expose_frame(*w, *radiance, r, out, wheel ? &(*mix)[static_cast<std::size_t>(wheel->position() - 1)] : nullptr);
  };
}

void SimRig::show(std::shared_ptr<const ImageF> radiance) {
  if (camera_) camera_->set_source(static_source(std::move(radiance)));
}

void SimRig::show_world() {
  if (camera_) camera_->set_source(world_source());
}

FrameSource SimRig::world_source() {
  SimWorld* w = world_.get();
  TurntableServer* table = turntable_.get();
  SimLight* light = light_.get();
  std::shared_ptr<Cache> cache = cache_;
  const SimFilterWheel* wheel = wheel_.get();
  const std::vector<std::array<double, 3>>* mix = &wheel_mix_;
  return [w, table, light, cache, wheel, mix](const FrameRequest& r, std::uint16_t* out) {
    if (table) w->set_table_angle_deg(table->angle_deg());
    if (light) w->set_led_on(light->emitting());
    const double angle = w->table_angle_deg();
    const bool led = w->led_on();
    const void* paint = w->paint().brdf.get();
    const bool rgb = dev::cfa_pattern(r.format) != dev::CfaPattern::None || wheel;
    ImageF radiance;
    {
      std::lock_guard lock(cache->mutex);
      if (!cache->valid || cache->angle_deg != angle || cache->led_on != led || cache->paint != paint ||
          cache->rgb != rgb) {
        RenderOptions ro;
        ro.mono = !rgb;
        cache->radiance = w->render_at(angle, led, ro);
        cache->angle_deg = angle;
        cache->led_on = led;
        cache->rgb = rgb;
        cache->paint = paint;
        cache->valid = true;
      }
      radiance = cache->radiance;
    }
    // The wheel's slot when the frame is taken (a frame during a move sees the old slot).
    expose_frame(*w, radiance, r, out, wheel ? &(*mix)[static_cast<std::size_t>(wheel->position() - 1)] : nullptr);
  };
}

}  // namespace paintlab::sim
