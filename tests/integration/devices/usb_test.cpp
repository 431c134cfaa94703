// USB discovery with the real libusb against devices described to umockdev (umockdev-run):
// an FTDI RS-485 cable, a CP210x adapter, a USB3 Vision camera and a keyboard. The
// descriptors are built here, byte by byte, from the USB 2.0 / USB3 Vision layouts.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <fmt/format.h>
#include <string>
#include <vector>

#include "process_util.h"
#include "test_util.h"

namespace paintlab {
namespace {

using Bytes = std::vector<std::uint8_t>;

std::string hex(const Bytes& b) {
  std::string s;
  for (auto v : b) s += fmt::format("{:02X}", v);
  return s;
}

Bytes device_descriptor(std::uint16_t usb, std::uint8_t cls, std::uint8_t sub, std::uint8_t proto, std::uint16_t vid,
                        std::uint16_t pid) {
  return {18, 1, static_cast<std::uint8_t>(usb & 0xFF), static_cast<std::uint8_t>(usb >> 8), cls, sub, proto, 64,
          static_cast<std::uint8_t>(vid & 0xFF), static_cast<std::uint8_t>(vid >> 8), static_cast<std::uint8_t>(pid & 0xFF),
          static_cast<std::uint8_t>(pid >> 8), 0x00, 0x01, 1, 2, 3, 1};
}

Bytes interface(std::uint8_t number, std::uint8_t endpoints, std::uint8_t cls, std::uint8_t sub, std::uint8_t proto) {
  return {9, 4, number, 0, endpoints, cls, sub, proto, 0};
}

Bytes bulk_endpoint(std::uint8_t address) { return {7, 5, address, 2, 0x00, 0x02, 0}; }

Bytes configuration(std::uint8_t interfaces, const Bytes& body) {
  auto total = static_cast<std::uint16_t>(9 + body.size());
  Bytes c = {9, 2, static_cast<std::uint8_t>(total & 0xFF), static_cast<std::uint8_t>(total >> 8), interfaces, 1, 0, 0x80,
             50};
  c.insert(c.end(), body.begin(), body.end());
  return c;
}

Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

std::string umockdev_device(int bus, int dev, std::uint16_t vid, std::uint16_t pid, const Bytes& descriptors) {
  std::string d = hex(descriptors);
  return fmt::format(
      "P: /devices/pci0000:00/0000:00:14.0/usb{0}/{0}-{1}\n"
      "N: bus/usb/{0:03d}/{1:03d}={2}\n"
      "E: DEVNAME=/dev/bus/usb/{0:03d}/{1:03d}\n"
      "E: DEVTYPE=usb_device\nE: DRIVER=usb\nE: SUBSYSTEM=usb\n"
      "E: PRODUCT={3:x}/{4:x}/100\nE: BUSNUM={0:03d}\nE: DEVNUM={1:03d}\n"
      "A: bConfigurationValue=1\nA: bNumConfigurations=1\nA: busnum={0}\nA: devnum={1}\n"
      "H: descriptors={2}\nA: idProduct={4:04x}\nA: idVendor={3:04x}\nA: speed=480\n\n",
      bus, dev, d, vid, pid);
}

std::string rig_usb() {
  // FTDI FT232R RS-485 cable: vendor-specific interface, two bulk endpoints.
  Bytes ftdi = cat({device_descriptor(0x0200, 0, 0, 0, 0x0403, 0x6001),
                    configuration(1, cat({interface(0, 2, 0xFF, 0xFF, 0xFF), bulk_endpoint(0x81), bulk_endpoint(0x02)}))});
  Bytes cp210x = cat({device_descriptor(0x0110, 0, 0, 0, 0x10C4, 0xEA60),
                      configuration(1, cat({interface(0, 2, 0xFF, 0, 0), bulk_endpoint(0x81), bulk_endpoint(0x01)}))});
  // USB3 Vision camera: device class EF/02/01 (interface association), control interface
  // EF/05/00, event EF/05/01 and streaming EF/05/02 (USB3 Vision 1.0, section 3).
  Bytes iad = {8, 0x0B, 0, 3, 0xEF, 0x05, 0x00, 0};
  Bytes u3v = cat({device_descriptor(0x0300, 0xEF, 0x02, 0x01, 0x2676, 0xBA02),
                   configuration(3, cat({iad, interface(0, 2, 0xEF, 0x05, 0x00), bulk_endpoint(0x81),
                                         bulk_endpoint(0x01), interface(1, 1, 0xEF, 0x05, 0x01), bulk_endpoint(0x82),
                                         interface(2, 1, 0xEF, 0x05, 0x02), bulk_endpoint(0x83)}))});
  // A keyboard (HID): not of interest.
  Bytes kbd = cat({device_descriptor(0x0200, 0, 0, 0, 0x046D, 0xC31C),
                   configuration(1, cat({interface(0, 1, 0x03, 0x01, 0x01), bulk_endpoint(0x81)}))});
  return umockdev_device(1, 2, 0x0403, 0x6001, ftdi) + umockdev_device(1, 3, 0x10C4, 0xEA60, cp210x) +
         umockdev_device(2, 4, 0x2676, 0xBA02, u3v) + umockdev_device(1, 5, 0x046D, 0xC31C, kbd);
}

// umockdev preloads its library; an ASan build must not insist on coming first.
void allow_preload_under_asan() {
  const char* cur = std::getenv("ASAN_OPTIONS");
  std::string opts = cur ? cur : "";
  if (opts.find("verify_asan_link_order") == std::string::npos) {
    opts += std::string(opts.empty() ? "" : ":") + "verify_asan_link_order=0";
    setenv("ASAN_OPTIONS", opts.c_str(), 1);
  }
}

std::string run_probe(const std::string& file, bool all) {
  allow_preload_under_asan();
  std::vector<std::string> argv = {"umockdev-run", "-d", file, "--", PAINTLAB_USB_PROBE};
  if (all) argv.push_back("--all");
  test::Process p(argv);
  std::string out;
  while (auto line = p.read_line(20.0)) out += *line + "\n";
  EXPECT_EQ(p.wait_exit(10.0), 0) << out;
  return out;
}

class UsbDiscovery : public ::testing::Test {
 protected:
  void SetUp() override {
    test::Process check({"umockdev-run", "--version"});
    ASSERT_EQ(check.wait_exit(10.0), 0) << "umockdev-run not working (Debian package umockdev; scripts/setup.sh installs it)";
  }
};

TEST_F(UsbDiscovery, FindsSerialAdaptersAndUsb3VisionCamerasOnly) {
  test::TempDir dir;
  std::string file = (dir / "rig.umockdev").string();
  test::write_text(file, rig_usb());
  std::string out = run_probe(file, false);
  EXPECT_THAT(out, ::testing::HasSubstr("usb-serial 0403:6001 bus 1 address 2 FTDI FT232R USB-serial\n"));
  EXPECT_THAT(out, ::testing::HasSubstr("usb-serial 10c4:ea60 bus 1 address 3 Silicon Labs CP210x USB-serial\n"));
  EXPECT_THAT(out, ::testing::HasSubstr("usb3-vision 2676:ba02 bus 2 address 4 USB3 Vision camera\n"));
  EXPECT_THAT(out, ::testing::Not(::testing::HasSubstr("046d:c31c")));
  std::string all = run_probe(file, true);
  EXPECT_THAT(all, ::testing::HasSubstr("other 046d:c31c bus 1 address 5"));
}

TEST_F(UsbDiscovery, EmptyBusListsNothing) {
  test::TempDir dir;
  std::string file = (dir / "none.umockdev").string();
  test::write_text(file, "");
  EXPECT_EQ(run_probe(file, true), "");
}

TEST_F(UsbDiscovery, HotPlugReportsArrivalAndRemoval) {
#ifndef PAINTLAB_USB_HOTPLUG_PROBE
  GTEST_SKIP() << "libumockdev-dev not installed: no testbed to add devices at run time";
#else
  test::TempDir dir;
  std::string file = (dir / "cable.umockdev").string();
  Bytes ftdi = cat({device_descriptor(0x0200, 0, 0, 0, 0x0403, 0x6001),
                    configuration(1, cat({interface(0, 2, 0xFF, 0xFF, 0xFF), bulk_endpoint(0x81), bulk_endpoint(0x02)}))});
  test::write_text(file, umockdev_device(1, 7, 0x0403, 0x6001, ftdi));
  allow_preload_under_asan();
  test::Process p({"umockdev-wrapper", PAINTLAB_USB_HOTPLUG_PROBE, file, "/sys/devices/pci0000:00/0000:00:14.0/usb1/1-7"});
  std::string out;
  while (auto line = p.read_line(20.0)) out += *line + "\n";
  EXPECT_EQ(p.wait_exit(10.0), 0) << out;
  if (out.find("supported 0") != std::string::npos) GTEST_SKIP() << "libusb without hot-plug support";
  EXPECT_THAT(out, ::testing::HasSubstr("arrived usb-serial 0403:6001\nleft usb-serial 0403:6001\n"));
#endif
}

}  // namespace
}  // namespace paintlab
