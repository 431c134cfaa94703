#include "paintlab/devices/probe.h"

#include <fmt/format.h>

#include "paintlab/devices/aravis_camera.h"
#include "paintlab/devices/device_config.h"
#include "paintlab/devices/gpiod_light.h"
#include "paintlab/devices/modbus_turntable.h"
#include "paintlab/devices/serial_filter_wheel.h"
#include "paintlab/devices/usb_discovery.h"

namespace paintlab::dev {

namespace {

void probe_camera(const RigConfig* rig, const ProbeOptions& options, std::vector<ProbeLine>& out) {
  if (rig && rig->camera.kind == "aravis") {
    const auto cfg = camera_config(rig->camera, rig->geometry);
    if (auto p = probe_aravis_camera(cfg.id))
      out.push_back({fmt::format("camera  aravis {}: {} {}, serial {}, id {}", cfg.id, p->vendor, p->model, p->serial,
                                 p->device_id)});
    else
      out.push_back({fmt::format("camera  aravis {}: not reachable ({})", cfg.id, p.error().what()), true});
  } else if (rig) {
    out.push_back({"camera  sim: simulated (GigE Vision on 127.0.0.1 while `paintlab sim serve` or a measurement runs)"});
  }
  if (!options.discover) return;
  const auto found = discover_aravis_cameras();
  if (found.empty()) out.push_back({"camera  discovery: none found"});
  for (const auto& c : found)
    out.push_back({fmt::format("camera  discovered {} {} {}, serial {}, address {}", c.device_id, c.vendor, c.model,
                               c.serial, c.address)});
}

void probe_light(const RigConfig* rig, std::vector<ProbeLine>& out) {
  const auto chips = list_gpiochips();
  if (chips.empty()) out.push_back({"gpio    no gpiochip found"});
  for (const auto& c : chips) out.push_back({fmt::format("gpio    {} '{}', {} lines", c.name, c.label, c.lines)});
  if (rig && rig->light.kind == "gpiod") {
    const auto l = gpiod_config(rig->light);
    bool found = false;
    for (const auto& c : chips) found = found || c.name == l.chip || c.label == l.chip || "/dev/" + c.name == l.chip;
    out.push_back({fmt::format("light   gpiod {} line {}: {}", l.chip, l.line, found ? "chip present" : "chip not found"),
                   !found});
  } else if (rig) {
    out.push_back({"light   sim: simulated"});
  }
}

void probe_turntable(const RigConfig& rig, std::vector<ProbeLine>& out) {
  if (rig.turntable.kind == "sim") {
    out.push_back({"table   sim: simulated (Modbus on 127.0.0.1 while `paintlab sim serve` or a measurement runs)"});
    return;
  }
  auto cfg = turntable_config(rig.turntable);
  cfg.retries = 0;
  ModbusTurntable table(cfg);
  if (auto st = table.status())
    out.push_back({fmt::format("table   {}: reachable, at {:.3f} deg, {}{}{}", table.id(), st->angle_deg,
                               st->moving ? "moving" : "still", st->in_position ? ", in position" : "",
                               st->alarm_code ? fmt::format(", alarm {}", st->alarm_code) : std::string())});
  else
    out.push_back({fmt::format("table   {}: not reachable ({})", table.id(), st.error().what()), true});
}

void probe_filter_wheel(const RigConfig& rig, std::vector<ProbeLine>& out) {
  if (!rig.filter_wheel) return;
  const FilterWheelSetup setup = filter_wheel_config(*rig.filter_wheel);
  const std::string slots = fmt::format("R, G, B filters in slots {}, {}, {}", setup.channel_slot[0],
                                        setup.channel_slot[1], setup.channel_slot[2]);
  if (setup.kind == "sim") {
    out.push_back({"wheel   sim: simulated (" + slots + ")"});
    return;
  }
  SerialFilterWheelConfig cfg = setup.serial;
  cfg.retries = 0;
  try {
    SerialFilterWheel wheel(cfg);
    const Result<std::string> idn = wheel.identify();
    const Result<int> count = idn ? wheel.slot_count() : Result<int>(0);
    if (!idn || !count) {
      out.push_back({fmt::format("wheel   {}: not answering ({})", wheel.id(), (!idn ? idn.error() : count.error()).what()),
                     true});
      return;
    }
    out.push_back({fmt::format("wheel   {}: {}, {} slots; {}", wheel.id(), *idn, *count, slots)});
  } catch (const Error& e) {
    out.push_back({fmt::format("wheel   serial {}: not reachable ({})", cfg.port, e.what()), true});
  }
}

}  // namespace

std::vector<ProbeLine> probe_devices(const RigConfig* rig, const ProbeOptions& options) {
  std::vector<ProbeLine> out;
  probe_camera(rig, options, out);
  const auto usb = list_usb_devices(options.all_usb);
  if (usb.empty()) out.push_back({"usb     no USB3 Vision camera or USB-serial adapter found"});
  for (const auto& u : usb)
    out.push_back({fmt::format("usb     {} {} bus {} address {}: {}", to_string(u.kind), u.vid_pid(), u.bus, u.address,
                               u.description)});
  probe_light(rig, out);
  if (rig) {
    probe_turntable(*rig, out);
    probe_filter_wheel(*rig, out);
  }
  return out;
}

}  // namespace paintlab::dev
