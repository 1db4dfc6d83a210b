#include "relocalizer/core/outside_text.h"

namespace relocalizer {

namespace {

bool nameCharacter(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '-' || c == '.' || c == '/';
}

// The length of the UTF-8 character at text[i] (1 to 4), or 0 when the bytes
// there are none (stray continuation, overlong form, surrogate, beyond U+10FFFF).
size_t utf8Length(const std::string& text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char lead = byte(i);
  if (lead < 0x80) return 1;
  size_t length = 0;
  unsigned char low = 0x80, high = 0xbf;  // the second byte's range
  if (lead >= 0xc2 && lead <= 0xdf) {
    length = 2;
  } else if (lead >= 0xe0 && lead <= 0xef) {
    length = 3;
    if (lead == 0xe0) low = 0xa0;
    if (lead == 0xed) high = 0x9f;
  } else if (lead >= 0xf0 && lead <= 0xf4) {
    length = 4;
    if (lead == 0xf0) low = 0x90;
    if (lead == 0xf4) high = 0x8f;
  } else {
    return 0;
  }
  if (i + length > text.size()) return 0;
  if (byte(i + 1) < low || byte(i + 1) > high) return 0;
  for (size_t k = 2; k < length; ++k)
    if (byte(i + k) < 0x80 || byte(i + k) > 0xbf) return 0;
  return length;
}

}  // namespace

std::string nameError(const std::string& text, const std::string& what) {
  const auto quoted = [&] { return "'" + textExcerpt(text, 40) + "'"; };
  if (text.empty()) return what + " is empty";
  if (text.size() > kMaxNameBytes)
    return what + " " + quoted() + " is longer than " + std::to_string(kMaxNameBytes) + " bytes";
  for (const char c : text)
    if (!nameCharacter(c))
      return what + " " + quoted() +
             " holds a character other than ASCII letters, digits and _ - . /";
  if (text.front() == '/' || text.back() == '/' || text.find("//") != std::string::npos)
    return what + " " + quoted() + " has an empty part (a / at either end, or //)";
  return {};
}

std::string textExcerpt(const std::string& text, size_t max_bytes) {
  std::string excerpt;
  size_t i = 0;
  while (i < text.size()) {
    const size_t length = utf8Length(text, i);
    const size_t taken = length == 0 ? 1 : length;
    if (excerpt.size() + taken > max_bytes) break;
    const unsigned char c = static_cast<unsigned char>(text[i]);
    // A newline or escape sequence would split or garble the one log line.
    if (length == 0 || c < 0x20 || c == 0x7f)
      excerpt += '?';
    else
      excerpt.append(text, i, length);
    i += taken;
  }
  if (i < text.size()) excerpt += "... (" + std::to_string(text.size()) + " bytes)";
  return excerpt;
}

bool printableText(const std::string& text) {
  for (size_t i = 0; i < text.size();) {
    const size_t length = utf8Length(text, i);
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (length == 0 || c < 0x20 || c == 0x7f) return false;
    i += length;
  }
  return true;
}

}  // namespace relocalizer
