// Prints what paintlab's USB discovery finds, one device per line:
// "KIND VID:PID bus B address A DESCRIPTION". Run by usb_test.cpp under umockdev-run.
#include <cstdio>
#include <cstring>

#include "paintlab/core/error.h"
#include "paintlab/devices/usb_discovery.h"

int main(int argc, char** argv) {
  bool all = argc > 1 && std::strcmp(argv[1], "--all") == 0;
  try {
    for (const auto& d : paintlab::dev::list_usb_devices(all))
      std::printf("%s %s bus %d address %d %s\n", paintlab::dev::to_string(d.kind), d.vid_pid().c_str(), d.bus,
                  d.address, d.description.c_str());
  } catch (const paintlab::Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
