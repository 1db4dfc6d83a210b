#pragma once
// Frame-to-frame depth alignment: the relative motion between two depth
// images of one camera, measured from the images alone. Datasets check their
// ground truth with it (data/depth_alignment.h), and learn mode checks the
// motion SLAM claims between two key frames (online/slam_pose_check.h).
//
// The alignment is projective point-to-plane ICP started from a given relative
// pose: points of the moving frame are projected into the fixed frame and
// compared with the tangent plane there (normals from pixels `normal_step`
// apart, which averages over the Kinect's disparity steps), with a Huber
// weight. For consecutive frames (a centimetre and a degree apart) it converges
// from the ground-truth motion and from the identity alike.

#include <opencv2/core.hpp>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/pose.h"

namespace relocalizer {

struct DepthAlignmentParams {
  int stride = 3;       // pixels between the moving frame's samples
  int normal_step = 4;  // pixels between the points spanning a normal
  int iterations = 30;
  double max_residual = 0.05;  // metres; farther correspondences are occlusions
  double huber = 0.01;         // metres; residuals beyond it are down-weighted
  int min_correspondences = 500;
};

struct DepthAlignment {
  bool valid = false;  // false: too few correspondences or a singular system
  // Moving camera to fixed camera: p_fixed = motion * p_moving.
  Pose motion = Pose::Identity();
  double initial_rms = 0.0;  // point-to-plane RMS (metres) at the initial motion
  double final_rms = 0.0;    // and at the result
  int correspondences = 0;
};

// Depth images in metres (CV_32FC1, NaN invalid) of the same camera.
DepthAlignment alignDepth(const cv::Mat& fixed_depth, const cv::Mat& moving_depth,
                          const CameraIntrinsics& camera, const Pose& initial,
                          const DepthAlignmentParams& params = {});

// Translation (metres) and rotation (degrees) of a^-1 * b.
struct PoseDifference {
  double translation = 0.0;
  double rotation_deg = 0.0;
};
PoseDifference poseDifference(const Pose& a, const Pose& b);

}  // namespace relocalizer
