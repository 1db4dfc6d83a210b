#pragma once
// Whether a learned place changed where the camera looks (issue 40, a map that
// heals itself). A key frame taken where frozen submaps already hold one is
// not stored again (SubmapParams::cover_steps), unless what it sees no longer
// lies on their surface: furniture moved there, so that part is learned again
// while the unchanged parts add nothing. A place surveyed by `train` has no
// key-frame poses to tell where it was seen from: its surface alone says what
// it knows.

#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/online/submap_learner.h"

namespace relocalizer {

// What the frozen submaps know of the view of a key frame.
enum class ViewKnowledge {
  // A surveyed submap (SubmapIndex::surveyedSubmaps: a model made by `train`,
  // a surface but no key-frame poses) holds it: covered, not stored.
  kSurveyed,
  // As the frozen submaps that cover its pose learned it, or no submap has a
  // surface to compare with: the poses decide (SubmapIndex::decide).
  kAsLearned,
  // What it sees no longer lies on the surface of the frozen submaps covering
  // its pose, or, where none covers it, on a survey's (a changed or unsurveyed
  // part): learned again, unless the active submap holds a key frame as near
  // (it is learning that view already).
  kChanged,
};

// Which, for a key frame `frame` at SLAM's pose `camera_to_world`: a surface
// holds the frame's depth points when SubmapParams::relearn_agreement of them
// lie on it (surface_fit.h's agreement, at each relocalizer's surface
// settings); relearn_agreement 0: every view is as learned or surveyed.
ViewKnowledge viewKnowledge(const SubmapLearner& submaps, const RgbdFrame& frame,
                            const Pose& camera_to_world);

}  // namespace relocalizer
