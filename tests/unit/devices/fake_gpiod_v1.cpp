#include "fake_gpiod_v1.h"

#include <gpiod.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstring>
#include <new>
#include <string>

// libgpiod's structs are opaque to users: the fake defines its own.
struct gpiod_chip {
  int lines = 32;
};
struct gpiod_line {
  unsigned offset = 0;
};

namespace paintlab::test::fake_gpiod {

namespace {
State g_local;
State* g_state = &g_local;
gpiod_chip g_chip;
gpiod_line g_lines[32];
}  // namespace

State& state() { return *g_state; }

void reset(bool shared) {
  if (shared && g_state == &g_local) {
    void* p = mmap(nullptr, sizeof(State), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (p != MAP_FAILED) g_state = new (p) State();
  }
  *g_state = State();
}

}  // namespace paintlab::test::fake_gpiod

using paintlab::test::fake_gpiod::state;

namespace {
bool known_chip(const char* d) {
  std::string s = d ? d : "";
  return s == "gpiochip0" || s == "0" || s == "/dev/gpiochip0";
}
}  // namespace

extern "C" {

struct gpiod_chip* gpiod_chip_open(const char* path) {
  if (!known_chip(path)) {
    errno = ENOENT;
    return nullptr;
  }
  ++state().chips_open;
  return &paintlab::test::fake_gpiod::g_chip;
}

struct gpiod_chip* gpiod_chip_open_lookup(const char* descr) { return gpiod_chip_open(descr); }

void gpiod_chip_close(struct gpiod_chip*) { --state().chips_open; }

const char* gpiod_chip_name(struct gpiod_chip*) { return "gpiochip0"; }
const char* gpiod_chip_label(struct gpiod_chip*) { return "fake-gpio"; }
unsigned int gpiod_chip_num_lines(struct gpiod_chip*) { return 32; }

struct gpiod_line* gpiod_chip_get_line(struct gpiod_chip*, unsigned int offset) {
  if (offset >= 32) {
    errno = EINVAL;
    return nullptr;
  }
  paintlab::test::fake_gpiod::g_lines[offset].offset = offset;
  return &paintlab::test::fake_gpiod::g_lines[offset];
}

int gpiod_line_request_output_flags(struct gpiod_line* line, const char* consumer, int flags, int default_val) {
  auto& s = state();
  if (s.fail_request || s.requested) {
    errno = EBUSY;
    return -1;
  }
  s.requested = true;
  ++s.requests;
  s.offset = line->offset;
  s.active_low = (flags & GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW) != 0;
  std::strncpy(s.consumer, consumer ? consumer : "", sizeof s.consumer - 1);
  s.value = default_val;
  s.wire = s.active_low ? !default_val : default_val;
  return 0;
}

int gpiod_line_set_value(struct gpiod_line*, int value) {
  auto& s = state();
  if (!s.requested) {
    errno = EPERM;
    return -1;
  }
  ++s.set_calls;
  if (s.stuck) return 0;
  s.value = value;
  s.wire = s.active_low ? !value : value;
  return 0;
}

int gpiod_line_get_value(struct gpiod_line*) {
  auto& s = state();
  if (!s.requested) {
    errno = EPERM;
    return -1;
  }
  return s.active_low ? !s.wire : s.wire;
}

void gpiod_line_release(struct gpiod_line*) {
  auto& s = state();
  if (s.requested) ++s.releases;
  s.requested = false;
}

}  // extern "C"
