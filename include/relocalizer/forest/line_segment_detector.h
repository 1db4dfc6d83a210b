#pragma once
// Straight line segments of a grey image: our own implementation of LSD as
// published (Grompone von Gioi, Jakubowicz, Morel, Randall, "LSD: a Line
// Segment Detector", IPOL 2012): 2x2 gradient, pixels pseudo-ordered by
// gradient magnitude, regions grown from them within 22.5 degrees of the
// region's angle, a rectangle fitted to each region, shrunk while too few of
// its pixels belong to the region, and kept only when its number of false
// alarms under the a-contrario model is below 1.
//
// Why not OpenCV's: OpenCV 4.1.0 to 4.5.3 ship LSD as a stub that throws
// (Debian 11, Ubuntu 20.04), and a model must see the same line samples on
// every platform it is trained or used on. So everything that decides a
// segment is computed here in plain loops from integers and IEEE double
// arithmetic in a fixed order (no libm transcendental, no OpenCV filter whose
// rounding may change with the version, no unstable sort), and the source is
// compiled without floating-point contraction. Its input image from colour:
// line_detector_input.h.

#include <opencv2/core.hpp>
#include <vector>

namespace relocalizer {

struct LineSegment {
  // Endpoints in the image's pixel coordinates (pixel centres at integers);
  // from (x1, y1) to (x2, y2) the brighter side is on the left (y down).
  double x1 = 0, y1 = 0, x2 = 0, y2 = 0;
  double width = 0;       // of the fitted rectangle, pixels
  int region_pixels = 0;  // aligned pixels that grew the segment
};

// Segments of an 8-bit single-channel image, in the order their seeds were
// taken (strongest gradient first). Throws std::invalid_argument for another
// image type. validate = false keeps every region of at least the paper's
// minimum size (tests * p^size >= 1: 13 px at 160x120) as fitted, with
// neither the density check nor the NFA: what OpenCV's LSD_REFINE_NONE
// does, short low-contrast segments and noise included.
std::vector<LineSegment> detectLineSegments(const cv::Mat& grey, bool validate = true);

}  // namespace relocalizer
