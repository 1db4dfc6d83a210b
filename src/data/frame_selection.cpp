#include "relocalizer/data/frame_selection.h"

#include "relocalizer/core/id_ranges.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <optional>

namespace relocalizer {
namespace {

std::string trim(const std::string& s) {
  const auto is_space = [](unsigned char c) { return std::isspace(c) != 0; };
  auto begin = std::find_if_not(s.begin(), s.end(), is_space);
  auto end = std::find_if_not(s.rbegin(), s.rend(), is_space).base();
  return begin < end ? std::string(begin, end) : std::string();
}

// The problem with `text` as a frame number, or empty when `value` was set.
std::string parseFrameNumber(const std::string& text, int& value) {
  const bool digits_only =
      !text.empty() &&
      std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
  if (!digits_only)
    return "'" + text + "' is not a frame number (expected digits, or a range like 0-99)";
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size())
    return "frame number " + text + " is too large";
  return {};
}

// The problem with one comma-separated item, or empty when `range` was set.
std::string parseItem(const std::string& item, std::pair<int, int>& range) {
  if (item.empty()) return "is empty";
  const size_t dash = item.find('-');
  if (dash == std::string::npos) {
    std::string problem = parseFrameNumber(item, range.first);
    range.second = range.first;
    return problem;
  }
  if (item.find('-', dash + 1) != std::string::npos)
    return "has more than one '-' (expected a frame number or a range like 0-99)";
  const std::string start = trim(item.substr(0, dash));
  const std::string end = trim(item.substr(dash + 1));
  if (start.empty()) return "missing range start before '-' (frame numbers cannot be negative)";
  if (end.empty()) return "missing range end after '-'";
  if (std::string problem = parseFrameNumber(start, range.first); !problem.empty()) return problem;
  if (std::string problem = parseFrameNumber(end, range.second); !problem.empty()) return problem;
  if (range.second < range.first) return "range end " + end + " is before its start " + start;
  return {};
}

// Sorts and merges overlapping or adjacent ranges so contains() can binary
// search and str() is canonical.
std::vector<std::pair<int, int>> normalise(std::vector<std::pair<int, int>> ranges) {
  std::sort(ranges.begin(), ranges.end());
  std::vector<std::pair<int, int>> merged;
  for (const auto& range : ranges) {
    // Written as a subtraction so INT_MAX cannot overflow.
    if (!merged.empty() && range.first - 1 <= merged.back().second)
      merged.back().second = std::max(merged.back().second, range.second);
    else
      merged.push_back(range);
  }
  return merged;
}

}  // namespace

Expected<FrameSelection> FrameSelection::parse(const std::string& expression) {
  const std::string trimmed = trim(expression);
  if (trimmed.empty() || trimmed == "all") return FrameSelection();

  std::vector<std::pair<int, int>> ranges;
  size_t begin = 0;
  for (int item_number = 1;; ++item_number) {
    const size_t comma = trimmed.find(',', begin);
    const std::string item = trim(trimmed.substr(begin, comma - begin));
    std::pair<int, int> range;
    const std::string problem = parseItem(item, range);
    if (!problem.empty()) {
      const std::string quoted = item.empty() ? std::string() : " '" + item + "'";
      return makeError("bad frame range expression '" + expression + "': item " +
                       std::to_string(item_number) + quoted + ": " + problem);
    }
    ranges.push_back(range);
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }

  FrameSelection selection;
  selection.all_ = false;
  selection.ranges_ = normalise(std::move(ranges));
  return selection;
}

bool FrameSelection::contains(int id) const {
  if (all_) return true;
  // First range starting after `id`; the one before it is the only candidate.
  auto it =
      std::upper_bound(ranges_.begin(), ranges_.end(), id,
                       [](int value, const std::pair<int, int>& r) { return value < r.first; });
  if (it == ranges_.begin()) return false;
  --it;
  return id <= it->second;
}

std::string FrameSelection::str() const { return all_ ? "all" : joinIdRanges(ranges_); }

}  // namespace relocalizer
