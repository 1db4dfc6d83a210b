#pragma once
// One decimal number read from text the same way on every platform and in every
// locale: a ROS node may run under a ',' decimal locale, and std::from_chars for
// double is missing from the C++ libraries of gcc 10 and older (Debian 11,
// Ubuntu 20.04), so every reader of numbers in files and options comes here.

#include <optional>
#include <string_view>

namespace relocalizer {

// The number that is all of `text` (an optional sign, decimal digits with an
// optional '.' and exponent, or inf / nan); nullopt for anything else,
// including surrounding spaces, hexadecimal and an empty text. Out-of-range
// magnitudes become +-inf or 0, as strtod gives them.
std::optional<double> parseDecimal(std::string_view text);

}  // namespace relocalizer
