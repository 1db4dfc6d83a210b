#pragma once
// Colour-to-depth registration: resampling the colour image so that pixel
// (u, v) of colour and depth show the same surface point.
//
// Why it matters: features compare colours around a depth pixel and label it
// with that pixel's 3D point. If colour is not registered, the colour read at
// a depth pixel belongs to a different surface point, and the offset between
// the two changes with the viewpoint (the colour camera of a Kinect has a
// shorter focal length, ~527 vs 585 px, and sits ~2.5 cm from the depth
// camera). Predictions then drift smoothly across the image, which RANSAC
// cannot remove: on 7-Scenes it biases poses by several centimetres.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "relocalizer/camera.h"

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

  // The Kinect v1 of Microsoft 7-Scenes, estimated from the shared redkitchen
  // frames by aligning depth discontinuities with colour edges (see
  // estimateColourRegistration): fx = fy = 527, cx = 322, cy = 239, colour
  // camera 3 cm to the depth camera's left (x = -0.03 m).
  static ColourRegistration sevenScenesKinect();
};

// Colour resampled (bilinear) onto the depth pixel grid. `colour` may have any
// size; the result has the depth image's size.
cv::Mat registerColourToDepth(const cv::Mat& colour, const cv::Mat& depth_metres,
                              const CameraIntrinsics& depth_camera,
                              const ColourRegistration& registration);

// Searches colour intrinsics and the x offset that best put colour edges on
// depth discontinuities, over the given frames (colour as captured, depth in
// metres). Returns the registration and, in `score`, the mean colour gradient
// on depth edges (higher is better aligned; an identity mapping is the baseline).
ColourRegistration estimateColourRegistration(const std::vector<cv::Mat>& colours,
                                              const std::vector<cv::Mat>& depths,
                                              const CameraIntrinsics& depth_camera,
                                              double* score = nullptr,
                                              double* identity_score = nullptr);

}  // namespace relocalizer
