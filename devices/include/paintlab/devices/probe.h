#pragma once
// What `paintlab devices` reports: what this machine reaches. The rig's camera is probed at its
// address (Aravis discovery, which broadcasts, only when asked), then USB devices (USB3 Vision
// cameras, USB-serial adapters), gpiochips, the rig's Modbus turntable and its serial filter
// wheel (asked `*idn?` and `pcount?`). Simulated devices are named as such, not probed.
#include <string>
#include <vector>

#include "paintlab/core/rig.h"

namespace paintlab::dev {

struct ProbeLine {
  std::string text;      // "camera  aravis 10.0.0.5: Basler acA1300, serial ..., id ..."
  bool missing = false;  // a configured real device that did not answer
};

struct ProbeOptions {
  bool discover = false;  // also run Aravis' discovery (broadcasts on every interface)
  bool all_usb = false;   // every USB device, not only cameras and serial adapters
};

// `rig`: null probes only what the machine has (USB, gpiochips, discovery when asked).
std::vector<ProbeLine> probe_devices(const RigConfig* rig, const ProbeOptions& options);

}  // namespace paintlab::dev
