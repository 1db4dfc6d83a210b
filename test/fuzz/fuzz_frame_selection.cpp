// FrameSelection::parse on arbitrary text (the --frames option of every tool),
// with the properties the header promises checked on every accepted input.

#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "relocalizer/core/id_ranges.h"
#include "relocalizer/data/frame_selection.h"

using relocalizer::FrameSelection;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string expression(reinterpret_cast<const char*>(data), size);
  auto selection = FrameSelection::parse(expression);
  if (!selection) {
    // Failures must name the expression (the header's promised format).
    if (selection.error().rfind("bad frame range expression '", 0) != 0) std::abort();
    return 0;
  }
  // parse(str()) gives the same selection.
  const std::string canonical = selection->str();
  auto again = FrameSelection::parse(canonical);
  if (!again || again->str() != canonical || again->all() != selection->all()) std::abort();

  // contains() agrees with itself around every range boundary in the text.
  std::vector<int> probes = {0, 1, 2, 99, 100, 1000, 2147483647};
  for (size_t i = 0; i < canonical.size() && probes.size() < 64; ++i) {
    if (canonical[i] < '0' || canonical[i] > '9') continue;
    long long value = 0;
    size_t j = i;
    while (j < canonical.size() && canonical[j] >= '0' && canonical[j] <= '9' &&
           value < (1LL << 40))
      value = value * 10 + (canonical[j++] - '0');
    if (value <= 2147483647LL) {
      probes.push_back(static_cast<int>(value));
      if (value > 0) probes.push_back(static_cast<int>(value - 1));
      if (value < 2147483647LL) probes.push_back(static_cast<int>(value + 1));
    }
    i = j;
  }
  std::vector<int> inside;
  for (int id : probes)
    if (selection->contains(id) != again->contains(id))
      std::abort();
    else if (selection->contains(id))
      inside.push_back(id);
  if (selection->all() && inside.size() != probes.size()) std::abort();

  // formatIdRanges of the selected probes parses back to a selection holding them.
  const std::string ranges = relocalizer::formatIdRanges(inside);
  if (!inside.empty()) {
    auto back = FrameSelection::parse(ranges);
    if (!back) std::abort();
    for (int id : inside)
      if (!back->contains(id)) std::abort();
  }
  return 0;
}
