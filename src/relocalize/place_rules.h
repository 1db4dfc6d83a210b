#pragma once
// The place search's rules about places (place_search.h): which places are one
// map, what a hint makes a place's evidence count for, and the messages of a
// frame that fits two places alike.

#include <string>

#include "relocalizer/pose/pose_hint.h"
#include "relocalizer/relocalize/place.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer::detail {

inline int inliersOf(const Relocalization& answer) {
  return answer.point_inliers + answer.line_inliers;
}

// The hint for a place: only a place in the hint's frame hears it.
inline const PoseHint* hintFor(const Place& place, const PoseHint* hint) {
  return hint && hint->frame == place.map_frame ? hint : nullptr;
}

// What a place's evidence counts for against another place: its hint's factor
// at the pose (the largest, 1 + hint_weight, for a screen that has no pose).
// Float, as the ratios it meets are: without a hint every comparison is the
// one made before hints existed.
float hintFactor(const Place& place, const PoseHint* hint, const Pose* pose);

// One map: answers of the two places are poses in one world, so agreeing
// ones are one answer. Places of one group share their frame (put refuses
// otherwise); the frame is checked again so that the rule never compares
// poses of two worlds.
inline bool oneMap(const Place& a, const Place& b) {
  return !a.group.empty() && a.group == b.group && a.map_frame == b.map_frame;
}

// One map, but learned in two stretches of SLAM's map that may disagree
// (Place::part).
inline bool otherPart(const Place& a, const Place& b) { return oneMap(a, b) && a.part != b.part; }

std::string ambiguityMessage(const std::string& a, const Relocalization& answer_a,
                             const std::string& b, const Relocalization& answer_b);
// The same for two places of one map whose poses disagree.
std::string disagreementMessage(const std::string& a, const Relocalization& answer_a,
                                const std::string& b, const Relocalization& answer_b);

}  // namespace relocalizer::detail
