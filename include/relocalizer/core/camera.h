#pragma once
// Pinhole intrinsics of the depth camera. Pixel (u, v) with depth z (metres,
// along the optical axis) back-projects to ((u - cx) z / fx, (v - cy) z / fy, z)
// in the camera frame: x right, y down, z forward (ROS optical frame).

#include <Eigen/Core>
#include <cmath>
#include <string>

namespace relocalizer {

struct CameraIntrinsics {
  double fx = 585.0;
  double fy = 585.0;
  double cx = 320.0;
  double cy = 240.0;
  int width = 640;
  int height = 480;

  // The 7-Scenes / 12-Scenes default Kinect depth camera.
  static CameraIntrinsics kinectDefault() { return CameraIntrinsics{}; }

  Eigen::Vector3f backProject(float u, float v, float depth) const {
    return {static_cast<float>((u - cx) * depth / fx), static_cast<float>((v - cy) * depth / fy),
            depth};
  }
  // Returns (u, v); z must be positive.
  Eigen::Vector2f project(const Eigen::Vector3f& point) const {
    return {static_cast<float>(fx * point.x() / point.z() + cx),
            static_cast<float>(fy * point.y() / point.z() + cy)};
  }

  // Empty when usable, otherwise why not.
  std::string validationError() const {
    if (!(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0))
      return "focal length must be finite and positive (fx=" + std::to_string(fx) +
             ", fy=" + std::to_string(fy) + ")";
    if (!(std::isfinite(cx) && std::isfinite(cy))) return "principal point must be finite";
    if (width <= 0 || height <= 0)
      return "image size must be positive (" + std::to_string(width) + "x" +
             std::to_string(height) + ")";
    return {};
  }

  // Intrinsics for the same camera at a different resolution.
  CameraIntrinsics scaledTo(int new_width, int new_height) const {
    const double sx = static_cast<double>(new_width) / width;
    const double sy = static_cast<double>(new_height) / height;
    return {fx * sx, fy * sy, (cx + 0.5) * sx - 0.5, (cy + 0.5) * sy - 0.5, new_width, new_height};
  }
};

}  // namespace relocalizer
