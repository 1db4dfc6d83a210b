#pragma once
// One RGB-D observation, the unit every stage works on. Colour and depth have
// the same size and share the depth camera's intrinsics (datasets whose colour
// is a different resolution are resampled by their reader).

#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"

namespace relocalizer {

struct RgbdFrame {
  cv::Mat colour;  // CV_8UC3, BGR
  cv::Mat depth;   // CV_32FC1, metres along the optical axis, NaN where invalid
  CameraIntrinsics camera;
  double stamp = 0.0;                // seconds; datasets without time use the frame number
  int id = -1;                       // frame number within its dataset
  std::optional<Pose> ground_truth;  // camera-to-world, when known
  std::string source;                // where it came from, for error messages (file or topic)
};

// Depth in metres with NaN for invalid pixels, from:
//  - CV_16UC1 in units of 1 / units_per_metre metres (1000 for Kinect/7-Scenes
//    millimetres, 5000 for TUM); 0 and 65535 are invalid;
//  - CV_32FC1 in metres; non-finite and non-positive values are invalid.
Expected<cv::Mat> depthToMetres(const cv::Mat& raw, double units_per_metre = 1000.0);

// Metres (CV_32FC1, NaN = invalid) to 16-bit millimetres (0 = invalid): the
// 7-Scenes depth file format and REP 118's 16UC1. Rounded to the nearest
// millimetre; depths that round outside 1-65534 mm are invalid.
cv::Mat depthToMillimetres(const cv::Mat& metres);

// Empty when the frame can be relocalized, otherwise the reason: wrong types,
// colour/depth/intrinsics size mismatch, unusable intrinsics.
std::string frameValidationError(const RgbdFrame& frame);

// Number of pixels with valid depth.
int countValidDepth(const cv::Mat& depth);

}  // namespace relocalizer
