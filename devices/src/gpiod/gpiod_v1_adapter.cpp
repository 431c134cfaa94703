#include "gpiod/gpiod_v1_adapter.h"

#include <gpiod.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>

namespace paintlab::dev::gpiod_v1 {

namespace {
gpiod_chip* chip_of(const OutputLine& l) { return static_cast<gpiod_chip*>(l.chip); }
gpiod_line* line_of(const OutputLine& l) { return static_cast<gpiod_line*>(l.line); }
}  // namespace

bool request_output(const std::string& chip, unsigned offset, const std::string& consumer, bool active_low,
                    int initial_value, OutputLine* out, std::string* error) {
  gpiod_chip* c = gpiod_chip_open_lookup(chip.c_str());
  if (!c) {
    *error = "cannot open gpiochip '" + chip + "': " + std::strerror(errno);
    return false;
  }
  gpiod_line* l = gpiod_chip_get_line(c, offset);
  if (!l) {
    int e = errno;
    gpiod_chip_close(c);
    *error = "gpiochip '" + chip + "' has no line " + std::to_string(offset) + ": " + std::strerror(e);
    return false;
  }
  int flags = active_low ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0;
  if (gpiod_line_request_output_flags(l, consumer.c_str(), flags, initial_value) != 0) {
    int e = errno;
    gpiod_chip_close(c);
    *error = "cannot request line " + std::to_string(offset) + " of '" + chip + "' as output: " + std::strerror(e);
    return false;
  }
  out->chip = c;
  out->line = l;
  return true;
}

int set_value(const OutputLine& l, int value) { return gpiod_line_set_value(line_of(l), value); }

int get_value(const OutputLine& l) { return gpiod_line_get_value(line_of(l)); }

void release_line(const OutputLine& l) {
  if (l.line) gpiod_line_release(line_of(l));
}

void close_chip(OutputLine& l) {
  if (l.chip) gpiod_chip_close(chip_of(l));
  l.chip = nullptr;
  l.line = nullptr;
}

std::vector<ChipInfo> list_chips() {
  std::vector<ChipInfo> out;
  std::error_code ec;
  std::vector<std::string> paths;
  for (const auto& e : std::filesystem::directory_iterator("/dev", ec)) {
    std::string name = e.path().filename().string();
    if (name.rfind("gpiochip", 0) == 0) paths.push_back(e.path().string());
  }
  std::sort(paths.begin(), paths.end());
  for (const auto& p : paths) {
    gpiod_chip* c = gpiod_chip_open(p.c_str());
    if (!c) continue;
    out.push_back({gpiod_chip_name(c), gpiod_chip_label(c), gpiod_chip_num_lines(c)});
    gpiod_chip_close(c);
  }
  return out;
}

}  // namespace paintlab::dev::gpiod_v1
