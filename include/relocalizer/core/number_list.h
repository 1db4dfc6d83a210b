#pragma once
// Comma-separated numbers as options give them ("0.05,5"): one reader, so
// every such option accepts and refuses the same texts.

#include <string>
#include <vector>

#include "relocalizer/core/expected.h"

namespace relocalizer {

// The finite numbers of `text`, items trimmed of spaces and tabs. The error
// says which item is wrong (an empty item, not a number, not finite); the
// caller adds which option it was and what it expects.
Expected<std::vector<double>> parseNumberList(const std::string& text);

}  // namespace relocalizer
