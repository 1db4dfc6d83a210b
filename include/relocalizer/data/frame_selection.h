#pragma once
// Which frames of a dataset to use, written the way evaluation protocols are
// (the 7-Scenes redkitchen-dev protocol trains on "0-99,200-299,400-499"), so
// a protocol can be passed on the command line verbatim.

#include <string>
#include <utility>
#include <vector>

#include "relocalizer/core/expected.h"

namespace relocalizer {

class FrameSelection {
 public:
  // Selects every frame, so "no option given" needs no special case.
  FrameSelection() = default;

  // Comma-separated items, each a frame number ("5") or an inclusive range
  // ("0-99"); whitespace around numbers, dashes and commas is ignored. "" and
  // "all" select every frame. Failures read
  //   bad frame range expression '<expr>': item <n> '<item>': <problem>
  // so a typo in a long protocol string is easy to find.
  static Expected<FrameSelection> parse(const std::string& expression);

  bool contains(int id) const;
  // True when nothing was excluded; lets readers skip filtering and summaries
  // say "all".
  bool all() const { return all_; }
  // Canonical form (sorted, overlapping and adjacent ranges merged), "all" for
  // every frame; parse(str()) gives the same selection.
  std::string str() const;

 private:
  bool all_ = true;
  std::vector<std::pair<int, int>> ranges_;  // sorted, disjoint, inclusive
};

}  // namespace relocalizer
