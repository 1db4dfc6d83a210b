#pragma once
// Colour-to-depth registration: resampling the colour image so that pixel
// (u, v) of colour and depth show the same surface point.
//
// Why it matters: features compare colours around a depth pixel and label it
// with that pixel's 3D point. If colour is not registered, the colour read at
// a depth pixel belongs to a different surface point, and the offset between
// the two changes with the viewpoint (the colour camera of a Kinect has a
// shorter focal length, ~520 vs 585 px, and sits ~2.5 cm from the depth
// camera). Predictions then drift smoothly across the image, which RANSAC
// cannot remove: on 7-Scenes it biases poses by several centimetres.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/pose.h"

namespace relocalizer {

struct ColourRegistration {
  // Colour camera pinhole intrinsics at the colour image's resolution.
  double fx = 0, fy = 0, cx = 0, cy = 0;
  // Colour camera origin seen from the depth camera (metres); the two cameras
  // are taken as parallel (a Kinect's are, to well under a degree).
  Eigen::Vector3d depth_to_colour = Eigen::Vector3d::Zero();
  // Depth assumed where the depth image has none, so the colour there is still
  // taken from about the right place.
  double fallback_depth = 2.0;

  bool enabled() const { return fx > 0 && fy > 0; }

  // The Kinect v1 of Microsoft 7-Scenes: the colour camera 2.5 cm to the
  // right of the depth camera (the sensor's layout; the offset is barely
  // observable, see estimateColourRegistration) and fx = fy = 521.5,
  // cx = 321.5, cy = 237 estimated by estimateColourRegistration from every
  // third training frame (0-99, 200-299, 400-499) of the shared redkitchen
  // sequence. It puts depth silhouettes on colour edges to about a pixel; the
  // earlier edge-gradient estimate (527, 322, 239, x = -0.03 m) left them
  // ~20 px to the right at 1.5 m.
  static ColourRegistration sevenScenesKinect();
};

// Colour resampled (bilinear) onto the depth pixel grid. `colour` may have any
// size; the result has the depth image's size.
cv::Mat registerColourToDepth(const cv::Mat& colour, const cv::Mat& depth_metres,
                              const CameraIntrinsics& depth_camera,
                              const ColourRegistration& registration);

// One posed frame as captured: colour not registered, depth in metres.
struct PosedRgbd {
  cv::Mat colour;  // CV_8UC3, any size
  cv::Mat depth;   // CV_32FC1 metres, NaN invalid
  Pose pose;       // camera-to-world of the depth camera
};

// Mean photometric disagreement (grey levels, truncated at 30) between posed
// frames seen through `registration`: textured depth pixels of one frame are
// moved into another frame by the poses, both colours are read through the
// registration, and they should agree where both depths see the point (no
// occlusion). Each frame is paired with up to 8 others whose viewpoint differs
// (5 cm or 3 degrees, up to 2 m and 60 degrees). Deterministic.
class PhotometricConsistency {
 public:
  PhotometricConsistency(const std::vector<PosedRgbd>& frames, const CameraIntrinsics& depth_camera,
                         int samples_per_pair = 300);
  double cost(const ColourRegistration& registration) const;
  size_t correspondences() const { return pairs_.size(); }

 private:
  struct Correspondence {
    Eigen::Vector3f a, b;  // the same surface point in the depth cameras of frames i and j
    int i, j;
  };
  std::vector<cv::Mat> grey_;  // CV_32F, blurred
  std::vector<Correspondence> pairs_;
};

// Calibrates colour to depth by multi-view photo-consistency: minimises
// PhotometricConsistency over fx = fy, cx, cy (and, with `fit_offset`, the
// colour camera's x, y offset) by coordinate descent with halving steps, from
// `initial`. Needs frames with accurate poses (the training frames of a scene)
// that see the same surfaces from different places; colour edges alone (the
// depth silhouette against the colour gradient) proved ambiguous along the
// rows on 7-Scenes. The offset is weakly observable: shifting the principal
// point by f * dx / z mimics an offset dx at depth z, and only the spread of
// depths separates the two; at 1-3 m the cost barely changes along that
// ridge. Prefer the sensor's known baseline in `initial` and fit_offset =
// false. `cost` and `initial_cost`, if given, receive the consistency at the
// result and at `initial`.
ColourRegistration estimateColourRegistration(const std::vector<PosedRgbd>& frames,
                                              const CameraIntrinsics& depth_camera,
                                              const ColourRegistration& initial,
                                              bool fit_offset = false, double* cost = nullptr,
                                              double* initial_cost = nullptr);

}  // namespace relocalizer
