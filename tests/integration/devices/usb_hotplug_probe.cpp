// Hot-plug through paintlab's UsbHotplugWatcher and the real libusb, with devices that a
// umockdev testbed adds and removes (run under umockdev-wrapper by usb_test.cpp).
// Usage: devices_usb_hotplug_probe FILE.umockdev SYSFS_PATH
// Prints "supported 0|1", then "arrived|left KIND VID:PID" per event.
#include <umockdev.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <string>
#include <vector>

#include "paintlab/devices/usb_discovery.h"

int main(int argc, char** argv) {
  if (argc != 3) return 2;
  // The testbed must exist before libusb starts (it finds the fake sysfs through it).
  UMockdevTestbed* tb = umockdev_testbed_new();
  std::mutex m;
  std::condition_variable cv;
  std::vector<std::string> events;
  paintlab::dev::UsbHotplugWatcher watcher([&](const paintlab::dev::UsbDeviceInfo& d, bool arrived) {
    std::lock_guard lock(m);
    events.push_back(std::string(arrived ? "arrived " : "left ") + paintlab::dev::to_string(d.kind) + " " + d.vid_pid());
    cv.notify_all();
  });
  std::printf("supported %d\n", watcher.supported() ? 1 : 0);
  gchar* contents = nullptr;
  GError* err = nullptr;
  if (!g_file_get_contents(argv[1], &contents, nullptr, &err) || !umockdev_testbed_add_from_string(tb, contents, &err)) {
    std::printf("error %s\n", err ? err->message : "?");
    return 1;
  }
  g_free(contents);
  auto wait_for = [&](std::size_t n) {
    std::unique_lock lock(m);
    cv.wait_for(lock, std::chrono::seconds(5), [&] { return events.size() >= n; });
  };
  umockdev_testbed_uevent(tb, argv[2], "add");
  wait_for(1);
  umockdev_testbed_uevent(tb, argv[2], "remove");
  wait_for(2);
  std::lock_guard lock(m);
  for (const auto& e : events) std::printf("%s\n", e.c_str());
  std::fflush(stdout);
  g_object_unref(tb);
  return 0;
}
