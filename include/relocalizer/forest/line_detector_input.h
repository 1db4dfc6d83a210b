#pragma once
// The line segment detector's input (line_segment_detector.h) from a colour
// image: grey and scaled, computed alike on every platform, as the segments
// must be.

#include <opencv2/core.hpp>

namespace relocalizer {

// The detector's input from a BGR8 colour image: BT.601 luma in 14-bit fixed
// point, then shrunk by `scale` (<= 1) by averaging the source area each
// output pixel covers (to round(cols * scale) x round(rows * scale)), in our
// own loops so that the input, too, is the same everywhere.
cv::Mat lineDetectorInput(const cv::Mat& bgr, float scale);

}  // namespace relocalizer
