#pragma once
// A weak answer is given only when a second, independent draw confirms it.
//
// In changed light (a warm lamp, two stops less light) the forests' colour
// comparisons go astray on most samples, and a consensus of 15-21 % of them
// can pass the evidence gates (min_inliers, min_inlier_ratio, the surface
// check) at a pose 10 cm to 2.7 m from the truth: 9 of about 4,400 answers
// in bench-places' nine rooms under eleven lights (docs/benchmarks.md, "A
// second draw for weak answers"). Those consensuses are chance alignments of
// wrong predictions: the same frame drawn again (other pixels, another
// RANSAC stream) finds another pose or none, where a right answer is found
// again. Strong answers (every redkitchen-dev test frame in its recorded
// light has 30 % or more) are not asked twice and cost nothing.

#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

// The answer must be confirmed: it has a pose whose inlier share (score) is
// below `confirm_below`.
bool needsSecondDraw(const Relocalization& answer, float confirm_below);

// `first` (which needsSecondDraw) given as confirmed when `second` has a
// pose that agrees with it (core/pose.h's posesAgree); otherwise "no pose",
// with a reason that says what the second draw found. The time of both is
// the answer's.
Relocalization confirmedBySecondDraw(Relocalization first, const Relocalization& second,
                                     float confirm_below);

}  // namespace relocalizer
