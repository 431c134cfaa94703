#pragma once
// Text checks for what users type and what files carry (names, notes, operator).
#include <cstddef>
#include <string_view>

namespace paintlab {

// The byte offset of the first byte that breaks UTF-8 (RFC 3629: no overlong forms, no
// surrogates, nothing above U+10FFFF, no sequence cut short), or npos when all is valid.
std::size_t first_invalid_utf8(std::string_view text);

}  // namespace paintlab
