#pragma once
// The one place that calls libgpiod (v1 API, 1.6 as in Debian bookworm). GpiodLight talks to
// GPIO only through these functions, so a port to libgpiod 2 touches this file alone, and the
// unit test links the driver against a small fake of the v1 functions used here.
#include <string>
#include <vector>

namespace paintlab::dev::gpiod_v1 {

// An open chip and one requested output line. Opaque pointers to libgpiod's structs.
struct OutputLine {
  void* chip = nullptr;
  void* line = nullptr;
};

// Opens `chip` (name "gpiochip0", number "0", label or /dev path) and requests line `offset`
// as an output with `initial_value` (logical; active-low inverts on the wire).
// Returns false and sets *error (with strerror) on failure; nothing stays open then.
bool request_output(const std::string& chip, unsigned offset, const std::string& consumer, bool active_low,
                    int initial_value, OutputLine* out, std::string* error);
// Logical value; 0 on success, -1 (errno set) on failure.
int set_value(const OutputLine& l, int value);
// Logical value read back from the kernel, or -1 (errno set).
int get_value(const OutputLine& l);
// Releases the line (the kernel then keeps the last value; callers switch it off first).
// Only system calls inside: safe in a signal handler.
void release_line(const OutputLine& l);
// Closes the chip (frees libgpiod's memory; not for signal handlers).
void close_chip(OutputLine& l);

struct ChipInfo {
  std::string name;   // gpiochip0
  std::string label;  // pinctrl-bcm2711
  unsigned lines = 0;
};
// The gpiochips under /dev.
std::vector<ChipInfo> list_chips();

}  // namespace paintlab::dev::gpiod_v1
