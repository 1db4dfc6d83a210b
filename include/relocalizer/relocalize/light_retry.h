#pragma once
// A frame the forests could not answer may have been seen in other light
// than the training frames: a warm lamp in the evening moves the colour
// channels apart, and the forests' colour comparisons with them, where a
// gain of the light moves both sides of each comparison alike. Such a frame
// is asked once more with its colour rebalanced to the light the forests
// learned in (TrainingSummary::light_chromaticity). Only frames that failed
// are asked again, so a frame answered in its own colour keeps the evidence
// of that colour (the furniture's colour is what tells a moved room's faces
// apart: docs/benchmarks.md, "Tried as the default, and reverted"). Among
// many places the same holds for the search that ranks them.

#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "relocalizer/forest/model_io.h"
#include "relocalizer/relocalize/place_search.h"

namespace relocalizer {

struct LightRebalance {
  cv::Vec3d gains;    // linear gain of each channel (B, G, R) into the training light
  double cast = 0.0;  // the largest |ln gain|: how far the frame's light is from it
};

// The rebalance that takes the frame's colour cast out, when the frame's
// light is at least `min_cast` from the training light (its chromaticity's
// largest |ln| ratio per channel); none when `min_cast` is 0, the model
// does not know its light (written before it was kept) or sees normalised
// colour (which has no cast to take out), or the frame has a black channel.
std::optional<LightRebalance> rebalanceIntoTrainingLight(const cv::Mat& bgr, const Model& model,
                                                         float min_cast);

// `first`, a frame's answer without a pose, or the frame asked again by
// `ask` with its colour rebalanced into the model's training light (when
// rebalanceIntoTrainingLight gives a rebalance; the answer carries its cast).
// When that fails too, the answer says both reasons.
Relocalization askedAgainInTrainingLight(
    const RgbdFrame& frame, Relocalization first, const Model& model, float min_cast,
    const std::function<Relocalization(const RgbdFrame&)>& ask);

// Many places: `first`, the search's answer, or when no place answered, the
// frame searched once more with its colour rebalanced into the light of the
// place it screened best on (at that place's light_retry_min_cast). The
// search ranks the places on the frame's own colour, so in a lamp's light a
// place the frame is not in can screen best: each place solved is asked
// again in its own light, but the right one may never be solved (bench-places'
// room-0 at 2700 K among 10 places: 58 %, alone 100 %). Not after an
// ambiguous search (two places answered: that is no failure of the light),
// nor with fewer than two places (one place asks again itself). When the
// second search fails too, the answer is `first`, with both reasons.
PlaceAnswer searchedAgainInTrainingLight(const std::vector<std::shared_ptr<const Place>>& places,
                                         const RgbdFrame& frame, const PoseHint* hint,
                                         const PlaceSearchParams& params, PlaceAnswer first);

}  // namespace relocalizer
