#pragma once
// Sets of frame ids written compactly, as evaluation protocols write them
// ("0-99,200-299"): for summaries, model headers and error messages that must
// show which frames exist without listing hundreds of them.

#include <string>
#include <utility>
#include <vector>

namespace relocalizer {

// Sorted, disjoint, inclusive ranges written "1-3,7-9,20" (a single id
// without a dash); empty for none.
std::string joinIdRanges(const std::vector<std::pair<int, int>>& ranges);

// Any ids: sorted, duplicates dropped, adjacent ids merged into ranges, then
// joined as above; "none" for no ids.
std::string formatIdRanges(std::vector<int> ids);

}  // namespace relocalizer
