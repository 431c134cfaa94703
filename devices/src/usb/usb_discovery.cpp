#include "paintlab/devices/usb_discovery.h"

#include <libusb.h>

#include <fmt/format.h>

#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"

namespace paintlab::dev {

const char* to_string(UsbKind k) {
  static constexpr EnumNames<UsbKind, 3> kNames{
      {{UsbKind::Usb3Vision, "usb3-vision"}, {UsbKind::UsbSerial, "usb-serial"}, {UsbKind::Other, "other"}}};
  return enum_name(kNames, k, "other");
}

std::string UsbDeviceInfo::vid_pid() const { return fmt::format("{:04x}:{:04x}", vendor_id, product_id); }

const std::vector<KnownUsbSerial>& known_usb_serial_adapters() {
  static const std::vector<KnownUsbSerial> table = {
      {0x0403, 0x6001, "FTDI FT232R USB-serial"},
      {0x0403, 0x6010, "FTDI FT2232 dual USB-serial"},
      {0x0403, 0x6011, "FTDI FT4232 quad USB-serial"},
      {0x0403, 0x6014, "FTDI FT232H USB-serial"},
      {0x0403, 0x6015, "FTDI FT-X series USB-serial"},
      {0x10c4, 0xea60, "Silicon Labs CP210x USB-serial"},
      {0x1a86, 0x7523, "WCH CH340 USB-serial"},
      {0x1a86, 0x55d4, "WCH CH9102 USB-serial"},
      {0x067b, 0x2303, "Prolific PL2303 USB-serial"},
  };
  return table;
}

namespace {

constexpr std::uint8_t kClassMisc = 0xEF;
constexpr std::uint8_t kSubclassU3v = 0x05;

bool has_u3v_interface(libusb_device* dev, const libusb_device_descriptor& d) {
  for (std::uint8_t c = 0; c < d.bNumConfigurations; ++c) {
    libusb_config_descriptor* cfg = nullptr;
    if (libusb_get_config_descriptor(dev, c, &cfg) != 0 || !cfg) continue;
    bool found = false;
    for (int i = 0; i < cfg->bNumInterfaces && !found; ++i)
      for (int a = 0; a < cfg->interface[i].num_altsetting && !found; ++a) {
        const libusb_interface_descriptor& id = cfg->interface[i].altsetting[a];
        found = id.bInterfaceClass == kClassMisc && id.bInterfaceSubClass == kSubclassU3v;
      }
    libusb_free_config_descriptor(cfg);
    if (found) return true;
  }
  return false;
}

UsbDeviceInfo describe(libusb_device* dev) {
  UsbDeviceInfo info;
  info.bus = libusb_get_bus_number(dev);
  info.address = libusb_get_device_address(dev);
  libusb_device_descriptor d{};
  if (libusb_get_device_descriptor(dev, &d) != 0) return info;
  info.vendor_id = d.idVendor;
  info.product_id = d.idProduct;
  for (const auto& k : known_usb_serial_adapters())
    if (k.vendor_id == d.idVendor && k.product_id == d.idProduct) {
      info.kind = UsbKind::UsbSerial;
      info.description = k.name;
      return info;
    }
  if (has_u3v_interface(dev, d)) {
    info.kind = UsbKind::Usb3Vision;
    info.description = "USB3 Vision camera";
    return info;
  }
  info.description = fmt::format("class {:02x}", d.bDeviceClass);
  return info;
}

}  // namespace

std::vector<UsbDeviceInfo> list_usb_devices(bool all) {
  libusb_context* ctx = nullptr;
  int rc = libusb_init(&ctx);
  if (rc != 0) throw DeviceError("usb", std::string("cannot initialise libusb: ") + libusb_error_name(rc), false);
  libusb_device** list = nullptr;
  ssize_t n = libusb_get_device_list(ctx, &list);
  std::vector<UsbDeviceInfo> out;
  for (ssize_t i = 0; i < n; ++i) {
    UsbDeviceInfo info = describe(list[i]);
    if (all || info.kind != UsbKind::Other) out.push_back(info);
  }
  if (list) libusb_free_device_list(list, 1);
  libusb_exit(ctx);
  return out;
}

struct UsbHotplugWatcher::Impl {
  libusb_context* ctx = nullptr;
  libusb_hotplug_callback_handle handle = 0;
  Callback callback;
  std::atomic<bool> stop{false};
  std::thread thread;

  static int LIBUSB_CALL on_event(libusb_context*, libusb_device* dev, libusb_hotplug_event event, void* self) {
    auto* impl = static_cast<Impl*>(self);
    UsbDeviceInfo info = describe(dev);
    if (info.kind != UsbKind::Other) impl->callback(info, event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED);
    return 0;
  }
};

UsbHotplugWatcher::UsbHotplugWatcher(Callback on_change) : impl_(std::make_unique<Impl>()) {
  impl_->callback = std::move(on_change);
  if (libusb_init(&impl_->ctx) != 0) {
    impl_->ctx = nullptr;
    return;
  }
  if (!libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG)) return;
  int rc = libusb_hotplug_register_callback(
      impl_->ctx,
      static_cast<libusb_hotplug_event>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
      LIBUSB_HOTPLUG_NO_FLAGS, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY,
      &Impl::on_event, impl_.get(), &impl_->handle);
  if (rc != LIBUSB_SUCCESS) return;
  supported_ = true;
  impl_->thread = std::thread([impl = impl_.get()] {
    while (!impl->stop.load()) {
      timeval tv{0, 100000};
      libusb_handle_events_timeout_completed(impl->ctx, &tv, nullptr);
    }
  });
}

UsbHotplugWatcher::~UsbHotplugWatcher() {
  impl_->stop.store(true);
  if (supported_) libusb_hotplug_deregister_callback(impl_->ctx, impl_->handle);
  if (impl_->thread.joinable()) impl_->thread.join();
  if (impl_->ctx) libusb_exit(impl_->ctx);
}

}  // namespace paintlab::dev
