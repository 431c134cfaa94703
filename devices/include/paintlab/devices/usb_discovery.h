#pragma once
// USB discovery (libusb 1.0) for `paintlab devices`: USB3 Vision cameras, recognised by
// their interface class (miscellaneous 0xEF, subclass 0x05 = USB3 Vision), and USB-serial
// adapters (RS-485 cables for the turntable), recognised by a table of VID:PID pairs.
// Hot-plug notifications where the platform supports them.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace paintlab::dev {

enum class UsbKind { Usb3Vision, UsbSerial, Other };
const char* to_string(UsbKind k);

struct UsbDeviceInfo {
  int bus = 0;
  int address = 0;
  std::uint16_t vendor_id = 0;
  std::uint16_t product_id = 0;
  UsbKind kind = UsbKind::Other;
  std::string description;  // from the VID:PID table, or the class ("USB3 Vision camera")
  std::string vid_pid() const;  // "0403:6001"
};

struct KnownUsbSerial {
  std::uint16_t vendor_id;
  std::uint16_t product_id;
  const char* name;
};
// The USB-serial adapters we recognise (FTDI, Silicon Labs CP210x, WCH CH340, Prolific).
const std::vector<KnownUsbSerial>& known_usb_serial_adapters();

// Enumerates the bus. Only USB3 Vision and known USB-serial devices unless `all`.
// Throws DeviceError when libusb cannot be initialised.
std::vector<UsbDeviceInfo> list_usb_devices(bool all = false);

// Calls `on_change(device, arrived)` from a background thread when a device of interest
// (USB3 Vision or known USB-serial) arrives or leaves. supported() is false where libusb
// has no hot-plug support; the watcher then does nothing.
class UsbHotplugWatcher {
 public:
  using Callback = std::function<void(const UsbDeviceInfo&, bool arrived)>;
  explicit UsbHotplugWatcher(Callback on_change);
  ~UsbHotplugWatcher();
  UsbHotplugWatcher(const UsbHotplugWatcher&) = delete;
  UsbHotplugWatcher& operator=(const UsbHotplugWatcher&) = delete;
  bool supported() const { return supported_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  bool supported_ = false;
};

}  // namespace paintlab::dev
