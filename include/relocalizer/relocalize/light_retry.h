#pragma once
// A frame the forests could not answer may have been seen in other light
// than the training frames: a warm lamp in the evening moves the colour
// channels apart, and the forests' colour comparisons with them, where a
// gain of the light moves both sides of each comparison alike. Such a frame
// is asked once more with its colour rebalanced to the light the forests
// learned in (TrainingSummary::light_chromaticity). Only frames that failed
// are asked again, so a frame answered in its own colour keeps the evidence
// of that colour (the furniture's colour is what tells a moved room's faces
// apart: docs/benchmarks.md, "Tried as the default, and reverted").

#include <optional>

#include <opencv2/core.hpp>

#include "relocalizer/forest/model_io.h"

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

}  // namespace relocalizer
