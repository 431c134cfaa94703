#include "paintlab/devices/camera.h"

#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"

namespace paintlab::dev {

constexpr EnumNames<PixelFormat, 3> kPixelFormatNames{
    {{PixelFormat::Mono8, "Mono8"}, {PixelFormat::Mono12, "Mono12"}, {PixelFormat::Mono16, "Mono16"}}};

const char* to_string(PixelFormat f) { return enum_name(kPixelFormatNames, f, "Mono16"); }

PixelFormat pixel_format_from_string(const std::string& s) {
  return enum_from_name(kPixelFormatNames, s, "pixel format");
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
