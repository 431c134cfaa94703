#include "paintlab/core/text.h"

#include <cstdint>
#include <string_view>

namespace paintlab {

std::size_t first_invalid_utf8(std::string_view s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      ++i;
      continue;
    }
    // The lead byte gives the length; 0xc0, 0xc1 and 0xf5.. only start overlong or too large forms.
    const std::size_t n = c >= 0xc2 && c <= 0xdf ? 1 : c >= 0xe0 && c <= 0xef ? 2 : c >= 0xf0 && c <= 0xf4 ? 3 : 0;
    if (n == 0 || i + n >= s.size()) return i;  // not a lead byte, or cut short
    std::uint32_t cp = c & (0x3fu >> n);
    for (std::size_t k = 1; k <= n; ++k) {
      const auto d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xc0u) != 0x80u) return i;
      cp = (cp << 6) | (d & 0x3fu);
    }
    const std::uint32_t min = n == 1 ? 0x80u : n == 2 ? 0x800u : 0x10000u;
    if (cp < min || cp > 0x10ffffu || (cp >= 0xd800u && cp <= 0xdfffu)) return i;
    i += n + 1;
  }
  return std::string_view::npos;
}

}  // namespace paintlab
