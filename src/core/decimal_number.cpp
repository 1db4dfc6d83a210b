#include "relocalizer/core/decimal_number.h"

#include <clocale>
#include <cstdlib>
#include <string>

#include <locale.h>

namespace relocalizer {

namespace {

// The "C" locale, made once: strtod_l reads with it whatever setlocale says.
locale_t classicLocale() {
  static const locale_t locale = newlocale(LC_ALL_MASK, "C", static_cast<locale_t>(nullptr));
  return locale;
}

}  // namespace

std::optional<double> parseDecimal(std::string_view text) {
  if (text.empty() || text.find_first_of(" \t\n\r\f\vxX") != std::string_view::npos)
    return std::nullopt;
  const std::string terminated(text);  // strtod_l needs the terminating NUL
  char* end = nullptr;
  const double value = strtod_l(terminated.c_str(), &end, classicLocale());
  if (end != terminated.c_str() + terminated.size()) return std::nullopt;
  return value;
}

}  // namespace relocalizer
