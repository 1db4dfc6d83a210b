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

// Whether `submaps` would cover a key frame `frame` at `camera_to_world`
// (SubmapIndex::coveringSubmaps is not empty) but on none of the covering frozen submaps' surfaces
// lies SubmapParams::relearn_agreement of its depth points (surface_fit.h's
// agreement, at each relocalizer's surface settings). False where no covering
// submap has a surface to compare with.
bool placeChanged(const SubmapLearner& submaps, const RgbdFrame& frame,
                  const Pose& camera_to_world);

// Whether a surveyed submap (SubmapIndex::surveyedSubmaps: a model made by
// `train`, which has a surface but no key-frame poses) already knows what a
// key frame `frame` at `camera_to_world` sees: SubmapParams::relearn_agreement
// of its depth points lie on that submap's surface. Such a key frame is
// covered; one that sees what the survey did not (furniture moved, or a part
// of the place it never saw) is learned. False where no surveyed submap has a
// surface; true for every key frame when relearn_agreement is 0 (never
// relearn).
bool surveyCovers(const SubmapLearner& submaps, const RgbdFrame& frame,
                  const Pose& camera_to_world);

}  // namespace relocalizer
