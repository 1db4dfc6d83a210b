#include "relocalizer/core/number_list.h"

#include <cmath>
#include <sstream>

#include "relocalizer/core/decimal_number.h"

namespace relocalizer {

Expected<std::vector<double>> parseNumberList(const std::string& text) {
  std::vector<double> values;
  // getline drops a trailing empty item.
  if (!text.empty() && text.back() == ',') return makeError("empty item");
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (item.empty()) return makeError("empty item");
    const auto value = parseDecimal(item);
    if (!value) return makeError("'" + item + "' is not a number");
    if (!std::isfinite(*value)) return makeError("'" + item + "' is not finite");
    values.push_back(*value);
  }
  return values;
}

}  // namespace relocalizer
