// nameError and textExcerpt (core/outside_text.h) on arbitrary bytes: the
// rule the node applies to place names and frame ids from service requests,
// messages and parameters, and the excerpt every such text goes through on
// its way into a log line or an answer. Checked on every input, against a
// second, plain reading of the header's promises.
//
// Input: one byte for max_bytes (0-255), then the text.

#include <cstdint>
#include <cstdlib>
#include <string>

#include "relocalizer/core/outside_text.h"

namespace {

// The header's rule, read plainly.
bool isName(const std::string& s) {
  if (s.empty() || s.size() > relocalizer::kMaxNameBytes) return false;
  for (const char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
          c == '-' || c == '.' || c == '/'))
      return false;
  return s.front() != '/' && s.back() != '/' && s.find("//") == std::string::npos;
}

// Valid UTF-8 without control characters: what a log line and a ROS string
// field may hold.
bool printableUtf8(const std::string& s) {
  for (size_t i = 0; i < s.size();) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c < 0x20 || c == 0x7f) return false;
    size_t n = c < 0x80                 ? 1
               : c >= 0xc2 && c <= 0xdf ? 2
               : c >= 0xe0 && c <= 0xef ? 3
               : c >= 0xf0 && c <= 0xf4 ? 4
                                        : 0;
    if (n == 0 || i + n > s.size()) return false;
    uint32_t code = n == 1 ? c : c & (0xff >> (n + 1));
    for (size_t k = 1; k < n; ++k) {
      const unsigned char d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xc0) != 0x80) return false;
      code = (code << 6) | (d & 0x3f);
    }
    const uint32_t least[5] = {0, 0, 0x80, 0x800, 0x10000};
    if (code < least[n] || code > 0x10ffff || (code >= 0xd800 && code <= 0xdfff)) return false;
    i += n;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const size_t max_bytes = data[0];
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);

  const std::string excerpt = relocalizer::textExcerpt(text, max_bytes);
  // Printable UTF-8, bounded, the text itself when it is printable and fits.
  if (!printableUtf8(excerpt)) std::abort();
  if (excerpt.size() > max_bytes + 32) std::abort();
  if (text.size() <= max_bytes && printableUtf8(text) && excerpt != text) std::abort();

  const std::string why = relocalizer::nameError(text, "name");
  if (why.empty() != isName(text)) std::abort();
  if (!why.empty() && (!printableUtf8(why) || why.size() > 200 || why.rfind("name ", 0) != 0))
    std::abort();
  return 0;
}
