#pragma once
// A learner's models as places: the one naming of a set of submaps in a place
// set (relocalize/place_set.h), for every holder of one (the node's learned
// places, evaluate --learn-frames --submaps, learn_benchmark, the SLAM check's
// question, a saved folder read back).

#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/online/submap_learner.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer {

// How a set with one model, submap 0's, is named. The node keeps the name a
// place had before submaps (`learned`); the tools name every submap alike.
enum class LoneSubmap { Indexed, AsThePlace };

// `models` (SubmapLearner::models(), read once by the caller) as places
// `<names.place>/<index>` of group `names.place` in `names.map_frame`. A
// frozen submap's identity is its file's: the same file loaded as another
// place into the frame is refused (place_set.h).
std::vector<Place> learnedPlaces(const std::vector<SubmapModel>& models, const SubmapNames& names,
                                 LoneSubmap lone = LoneSubmap::Indexed);

// The same put into `places` as the group `names.place` (replacing it).
Status putLearnedPlaces(PlaceSet& places, const std::vector<SubmapModel>& models,
                        const SubmapNames& names, LoneSubmap lone = LoneSubmap::Indexed);

}  // namespace relocalizer
