#pragma once
// Which pixels of a frame become forest samples: random pixels with valid depth
// for the point forest, and pixels spread evenly along LSD line segments for
// the line forest. Each line sample keeps the 3D line fitted (by RANSAC) to the
// back-projections of its segment, in camera coordinates; the pose solver's
// point-on-line energy needs it.

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "relocalizer/core/frame.h"

namespace relocalizer {

struct Sample {
  int16_t u = 0;
  int16_t v = 0;
  float depth = 0.0f;            // metres, valid
  Eigen::Vector3f camera_point;  // back-projection of (u, v, depth)
  int32_t line = -1;             // index into the frame's lines, or -1
};

struct Line3D {
  Eigen::Vector3f point;      // a point on the line, camera frame
  Eigen::Vector3f direction;  // unit
  float distance(const Eigen::Vector3f& p) const { return (p - point).cross(direction).norm(); }
};

// Which line segment detector finds the segments. Our own
// (line_segment_detector.h) gives the same segments on every platform and
// OpenCV version; OpenCV's LSD is what models trained before it used (and
// keep using: a model header without the key reads as OpenCV's), and OpenCV
// 4.1.0 to 4.5.3 do not have it.
enum class LineDetector { kOwn, kOpenCvLsd };
const char* lineDetectorName(LineDetector detector);  // "own", "opencv_lsd"
std::optional<LineDetector> lineDetectorNamed(const std::string& name);
// Empty where `detector` works here; otherwise why not, naming the setting
// (OpenCV's LSD is a stub that throws in 4.1.0 to 4.5.3: checked once, on a
// tiny image).
std::string lineDetectorMissing(LineDetector detector);

struct LineSamplingParams {
  LineDetector line_detector = LineDetector::kOwn;
  float min_segment_length_px = 20.0f;  // shorter LSD segments carry little structure
  float spacing_px = 5.0f;              // between samples along a segment
  // LSD on a downscaled image: far faster, and segments shorter than the
  // minimum length are dropped anyway. 1 = full resolution. A quarter takes a
  // third of half-size LSD's time on 640x480 frames at the same accuracy of
  // both forests over five training seeds (docs/benchmarks.md); models
  // trained at another scale keep theirs (it is stored in the model).
  float lsd_scale = 0.25f;
  // ... but the image LSD sees is never narrower than this (nor upscaled), so
  // a scale chosen for 640x480 frames does not starve LSD on small ones (a
  // quarter of 320 px is 80). 0 = no floor, the behaviour of models trained
  // before it existed.
  int lsd_min_width_px = 160;
  // Our detector's a-contrario validation (density check and NFA). Off (the
  // default), it keeps what OpenCV's LSD_REFINE_NONE keeps (96 % of its
  // segments to 0.005 px on redkitchen), weak and short segments included:
  // validated, the line forest alone lost 2-3 points within 2 cm / 2 deg
  // against OpenCV's LSD there (docs/benchmarks.md). Models without the key
  // validated (OpenCV's LSD ignores it).
  bool lsd_validation = false;
  // Samples are taken this many pixels off the detected edge, on both sides:
  // an intensity edge is often a depth edge, where depth is mixed or missing.
  float edge_offset_px = 0.0f;
  float ransac_inlier_m = 0.015f;  // point-to-line distance for inliers
  int ransac_iterations = 32;
  int min_inliers = 4;            // per segment, after RANSAC
  float min_inlier_ratio = 0.5f;  // of the segment's samples with depth
};

// The factor LSD's input is scaled by for an image `image_width` pixels wide:
// lsd_scale, raised so that the scaled image keeps lsd_min_width_px, at most 1.
float lsdScaleFor(const LineSamplingParams& params, int image_width);

// The segments (x1, y1, x2, y2) that `detector` finds in a BGR8 image scaled
// by `scale`, in the scaled image's pixels. Throws std::runtime_error naming
// the setting for OpenCV's LSD where this OpenCV does not have it.
std::vector<cv::Vec4f> detectSegments(const cv::Mat& colour, LineDetector detector, float scale,
                                      bool lsd_validation);

// Up to `count` distinct pixels with valid depth, uniformly at random. Appends.
void samplePoints(const RgbdFrame& frame, int count, std::mt19937& rng, std::vector<Sample>& out);

struct LineSamples {
  std::vector<Sample> samples;  // .line indexes `lines`
  std::vector<Line3D> lines;
  int segments_detected = 0;  // LSD segments before the length filter
  int segments_kept = 0;      // segments with a line fit
};

// LSD segments of at least the minimum length, sampled evenly; samples without
// depth are dropped, the rest back-projected and a 3D line fitted to each
// segment's points by RANSAC; only inliers are kept. If `max_samples` > 0 and
// more samples are found, a random subset of that size is kept.
LineSamples sampleLines(const RgbdFrame& frame, const LineSamplingParams& params, int max_samples,
                        std::mt19937& rng);

// RANSAC line fit to 3D points (exposed for tests). On success fills `line`
// (least-squares refit to the inliers) and `inliers` (indices into points).
bool fitLineRansac(const std::vector<Eigen::Vector3f>& points, float inlier_threshold,
                   int iterations, std::mt19937& rng, Line3D& line, std::vector<int>& inliers);

}  // namespace relocalizer
