#include "relocalizer/core/printable_text.h"

#include <cstddef>

namespace relocalizer {

bool printableText(std::string_view text) {
  for (size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f) return false;
    const size_t length = c < 0x80           ? 1
                          : (c >> 5) == 0x6  ? 2
                          : (c >> 4) == 0xe  ? 3
                          : (c >> 3) == 0x1e ? 4
                                             : 0;
    if (length == 0 || c == 0xc0 || c == 0xc1 || c > 0xf4 || i + length > text.size()) return false;
    for (size_t k = 1; k < length; ++k)
      if ((static_cast<unsigned char>(text[i + k]) & 0xc0) != 0x80) return false;
    // Overlong 3- and 4-byte forms, UTF-16 surrogates, code points past U+10FFFF.
    const auto next = static_cast<unsigned char>(length > 1 ? text[i + 1] : 0);
    if ((c == 0xe0 && next < 0xa0) || (c == 0xed && next >= 0xa0) || (c == 0xf0 && next < 0x90) ||
        (c == 0xf4 && next >= 0x90))
      return false;
    i += length;
  }
  return true;
}

}  // namespace relocalizer
