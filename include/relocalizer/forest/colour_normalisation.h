#pragma once
// What the forests see of a frame's colour. The split features compare
// absolute intensities, so light that is dimmer or warmer than in training
// moves every split's response. Seen against each channel's mean around the
// pixel, a gain and a colour cast of the light cancel out, also where they
// differ across the room (a lamp), and what walks into view changes only its
// surroundings; seen through the whole frame's statistics, an offset cancels
// too, but people in view shift every pixel. The features, the patch
// descriptors and the line detector see the image normalised.

#include <opencv2/core.hpp>
#include <optional>
#include <string>

namespace relocalizer {

enum class ColourNormalisation {
  kNone,               // the recorded colour (every model before issue 40)
  kChannelStatistics,  // each channel's mean to 128 and standard deviation to 48
  kLocalMean,          // each channel divided by its mean within 128 pixels, times 96
};

const char* colourNormalisationName(ColourNormalisation normalisation);
std::optional<ColourNormalisation> colourNormalisationNamed(const std::string& name);

// `bgr` (8-bit, 3 channels) as the forests see it under `normalisation`: the
// same Mat for kNone, otherwise a new one. The statistics are integer sums
// and the table is built in double from them, so the result is the same on
// every platform.
cv::Mat normaliseColour(const cv::Mat& bgr, ColourNormalisation normalisation);

}  // namespace relocalizer
