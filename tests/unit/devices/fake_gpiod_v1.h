#pragma once
// A small fake of the libgpiod v1 functions GpiodLight's adapter calls. One chip
// "gpiochip0" (also found as "0" or "/dev/gpiochip0") with 32 lines; the state can live in
// shared memory so a forked child's calls (the signal tests) are visible to the parent.
#include <cstdint>

namespace paintlab::test::fake_gpiod {

struct State {
  int chips_open = 0;
  int requests = 0;
  int releases = 0;
  int set_calls = 0;
  bool requested = false;
  bool active_low = false;
  unsigned offset = 0;
  char consumer[32] = {};
  int value = 0;          // logical value as last applied
  int wire = 0;           // level on the pin (active-low inverts)
  bool stuck = false;     // fault: set_value succeeds but the pin keeps its level
  bool fail_request = false;
};

State& state();
// Resets the state; with `shared`, the state moves to a shared anonymous mapping first.
void reset(bool shared = false);

}  // namespace paintlab::test::fake_gpiod
