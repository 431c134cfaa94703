#include "paintlab/devices/camera.h"

#include <array>
#include <utility>

#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"

namespace paintlab::dev {

constexpr EnumNames<PixelFormat, 16> kPixelFormatNames{{
    {PixelFormat::Mono8, "Mono8"},         {PixelFormat::Mono12, "Mono12"},       {PixelFormat::Mono16, "Mono16"},
    {PixelFormat::BayerRG8, "BayerRG8"},   {PixelFormat::BayerGR8, "BayerGR8"},   {PixelFormat::BayerGB8, "BayerGB8"},
    {PixelFormat::BayerBG8, "BayerBG8"},   {PixelFormat::BayerRG12, "BayerRG12"}, {PixelFormat::BayerGR12, "BayerGR12"},
    {PixelFormat::BayerGB12, "BayerGB12"}, {PixelFormat::BayerBG12, "BayerBG12"}, {PixelFormat::BayerRG16, "BayerRG16"},
    {PixelFormat::BayerGR16, "BayerGR16"}, {PixelFormat::BayerGB16, "BayerGB16"}, {PixelFormat::BayerBG16, "BayerBG16"},
    {PixelFormat::RGB8, "RGB8"},
}};

const char* to_string(PixelFormat f) { return enum_name(kPixelFormatNames, f, "Mono16"); }

PixelFormat pixel_format_from_string(const std::string& s) {
  return enum_from_name(kPixelFormatNames, s, "pixel format");
}

int bit_depth(PixelFormat f) {
  switch (f) {
    case PixelFormat::Mono8:
    case PixelFormat::BayerRG8:
    case PixelFormat::BayerGR8:
    case PixelFormat::BayerGB8:
    case PixelFormat::BayerBG8:
    case PixelFormat::RGB8:
      return 8;
    case PixelFormat::Mono12:
    case PixelFormat::BayerRG12:
    case PixelFormat::BayerGR12:
    case PixelFormat::BayerGB12:
    case PixelFormat::BayerBG12:
      return 12;
    case PixelFormat::Mono16:
    case PixelFormat::BayerRG16:
    case PixelFormat::BayerGR16:
    case PixelFormat::BayerGB16:
    case PixelFormat::BayerBG16:
      return 16;
  }
  return 16;
}

int channels(PixelFormat f) { return f == PixelFormat::RGB8 ? 3 : 1; }

CfaPattern cfa_pattern(PixelFormat f) {
  switch (f) {
    case PixelFormat::BayerRG8:
    case PixelFormat::BayerRG12:
    case PixelFormat::BayerRG16:
      return CfaPattern::RG;
    case PixelFormat::BayerGR8:
    case PixelFormat::BayerGR12:
    case PixelFormat::BayerGR16:
      return CfaPattern::GR;
    case PixelFormat::BayerGB8:
    case PixelFormat::BayerGB12:
    case PixelFormat::BayerGB16:
      return CfaPattern::GB;
    case PixelFormat::BayerBG8:
    case PixelFormat::BayerBG12:
    case PixelFormat::BayerBG16:
      return CfaPattern::BG;
    case PixelFormat::Mono8:
    case PixelFormat::Mono12:
    case PixelFormat::Mono16:
    case PixelFormat::RGB8:
      return CfaPattern::None;
  }
  return CfaPattern::None;
}

// PFNC codes as Aravis 0.8 defines them (arvenums.h): (bits per pixel << 16) | an index.
constexpr std::array<std::pair<PixelFormat, std::uint32_t>, 16> kPfncCodes{{
    {PixelFormat::Mono8, 0x01080001u},     {PixelFormat::Mono12, 0x01100005u},    {PixelFormat::Mono16, 0x01100007u},
    {PixelFormat::BayerGR8, 0x01080008u},  {PixelFormat::BayerRG8, 0x01080009u},  {PixelFormat::BayerGB8, 0x0108000Au},
    {PixelFormat::BayerBG8, 0x0108000Bu},  {PixelFormat::BayerGR12, 0x01100010u}, {PixelFormat::BayerRG12, 0x01100011u},
    {PixelFormat::BayerGB12, 0x01100012u}, {PixelFormat::BayerBG12, 0x01100013u}, {PixelFormat::BayerGR16, 0x0110002Eu},
    {PixelFormat::BayerRG16, 0x0110002Fu}, {PixelFormat::BayerGB16, 0x01100030u}, {PixelFormat::BayerBG16, 0x01100031u},
    {PixelFormat::RGB8, 0x02180014u},
}};

std::uint32_t pfnc_code(PixelFormat f) {
  for (const auto& [format, code] : kPfncCodes)
    if (format == f) return code;
  return 0x01100007u;  // Mono16 (unreachable: every format has its code)
}

std::optional<PixelFormat> pixel_format_from_pfnc(std::uint32_t code) {
  for (const auto& [format, c] : kPfncCodes)
    if (c == code) return format;
  return std::nullopt;
}

}  // namespace paintlab::dev
