#include "paintlab/devices/camera.h"

#include "paintlab/core/error.h"

namespace paintlab::dev {

const char* to_string(PixelFormat f) {
  switch (f) {
    case PixelFormat::Mono8: return "Mono8";
    case PixelFormat::Mono12: return "Mono12";
    case PixelFormat::Mono16: return "Mono16";
  }
  return "Mono16";
}

PixelFormat pixel_format_from_string(const std::string& s) {
  if (s == "Mono8") return PixelFormat::Mono8;
  if (s == "Mono12") return PixelFormat::Mono12;
  if (s == "Mono16") return PixelFormat::Mono16;
  throw DataError("unknown pixel format '" + s + "' (supported: Mono8, Mono12, Mono16)");
}

int bit_depth(PixelFormat f) {
  switch (f) {
    case PixelFormat::Mono8: return 8;
    case PixelFormat::Mono12: return 12;
    case PixelFormat::Mono16: return 16;
  }
  return 16;
}

}  // namespace paintlab::dev
