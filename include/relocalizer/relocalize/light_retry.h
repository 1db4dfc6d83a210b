#pragma once
// A frame the forests could not answer may have been seen in other light
// than the training frames: a warm lamp in the evening moves the colour
// channels apart, and the forests' colour comparisons with them, and a dim
// one moves every value down the camera's tone curve. Such a frame is asked
// once more with its colour rebalanced into the light the forests learned
// in. That light is found by matching where the frame's light falls
// (lightGrid) with each training view's (TrainingSummary::view_lights): the
// view the frame resembles under some level and lamp colour is a view of
// the same place, so that level and colour are the change of light. The
// mean chromaticity of the training images cannot tell a lamp from a
// coloured wall filling the view (bench-places' room-2 at 2700 K: 24 %
// asked that way, 100 % asked this way). Only frames that failed
// are asked again, so a frame answered in its own colour keeps the evidence
// of that colour (the furniture's colour is what tells a moved room's faces
// apart: docs/benchmarks.md, "Tried as the default, and reverted"). Among
// many places the same holds for the search that ranks them.

#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "relocalizer/core/photometric_change.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/relocalize/place_search.h"

namespace relocalizer {

struct LightRebalance {
  cv::Vec3d gains;    // linear gain of each channel (B, G, R) into the training light
  double cast = 0.0;  // the largest |ln gain|: how far the frame's light is from it
  // How unlike the nearest training view the frame stays once rebalanced
  // (LightChange::mismatch); infinite for a model without view lights.
  double mismatch = 0.0;
};

// A frame's light as the light of one training view changed: its level by
// 2^stops, its colour by whiteBalanceGains(kelvin) (a lamp of that colour
// temperature for a camera balanced for PhotometricChange::kBalancedKelvin).
struct LightChange {
  double stops = 0.0;
  double kelvin = PhotometricChange::kBalancedKelvin;
  // The variance of the cells' ln ratios left after the change: 0 when the
  // frame is the view itself in other light.
  double mismatch = 0.0;
  size_t view = 0;
};

// The training view and the change of light (kelvin among lamps 10 mired
// apart, about 1500 to 14000 K) that best explain `seen`; none when no view
// shares half of its grid's values with it (cells too dark or clipped).
std::optional<LightChange> nearestViewLight(const LightGrid& seen,
                                            const std::vector<LightGrid>& views);

// The rebalance into the model's training light, when the frame's light is
// at least `min_cast` from it (the largest |ln| gain of a channel): from the
// nearest training view (nearestViewLight) or, for models written before
// view lights were kept, from the mean chromaticity of the training images
// (colour only). None when `min_cast` is 0, the model does not know its
// light or sees normalised colour (which has no cast to take out), or the
// frame is too dark to tell.
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
// place whose training views it resembles most (the least mismatch; the
// place it screened best on when no place keeps view lights), at that
// place's light_retry_min_cast. The search ranks the places on the frame's
// own colour, so in a lamp's light a place the frame is not in can screen
// best: each place solved is asked again in its own light, but the right one
// may never be solved (bench-places' room-0 at 2700 K among 10 places: 58 %,
// alone 100 %). Not after an
// ambiguous search (two places answered: that is no failure of the light),
// nor with fewer than two places (one place asks again itself). When the
// second search fails too, the answer is `first`, with both reasons.
PlaceAnswer searchedAgainInTrainingLight(const std::vector<std::shared_ptr<const Place>>& places,
                                         const RgbdFrame& frame, const PoseHint* hint,
                                         const PlaceSearchParams& params, PlaceAnswer first);

}  // namespace relocalizer
