#pragma once
// Frame-to-frame depth alignment, and with it a check of a dataset's ground
// truth: the relative motion between two consecutive frames, measured from
// their depth images alone, should match the relative motion of their
// ground-truth poses.
//
// Why: relocalization is scored against reference poses, and reference poses
// of public datasets come from SLAM (7-Scenes: KinectFusion), which can jump
// or drift. On 7-Scenes redkitchen the reference pose jumps 3.6 cm / 1.4 deg
// between frames 121 and 122 while the images move 6 mm / 0.65 deg; every
// test frame after the jump is then scored against a pose several centimetres
// from where the images put it. Such frames fail the 5 cm / 5 deg test for any
// method that is consistent with the training frames, so a benchmark should
// know about them before reading its numbers.
//
// The alignment is projective point-to-plane ICP started from a given relative
// pose: points of the moving frame are projected into the fixed frame and
// compared with the tangent plane there (normals from pixels `normal_step`
// apart, which averages over the Kinect's disparity steps), with a Huber
// weight. For consecutive frames (a centimetre and a degree apart) it converges
// from the ground-truth motion and from the identity alike.

#include <opencv2/core.hpp>
#include <string>
#include <vector>

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

// One consecutive pair of a ground-truth check.
struct MotionCheck {
  int from_id = -1;
  int to_id = -1;
  PoseDifference ground_truth_motion;  // size of the GT relative motion
  PoseDifference depth_motion;         // size of the motion the depth images show
  PoseDifference disagreement;         // between the two motions
  double rms_at_ground_truth = 0.0;    // metres
  double rms_aligned = 0.0;
  bool aligned = false;  // the depth alignment succeeded
};

// Thresholds above which a pair's ground truth is called inconsistent. The
// defaults are ~5x what the check measures between consistent 7-Scenes frames
// (1-3 mm, 0.05-0.15 deg).
struct MotionCheckThresholds {
  double translation = 0.015;  // metres
  double rotation_deg = 0.75;
  bool flags(const MotionCheck& check) const {
    return check.aligned && (check.disagreement.translation > translation ||
                             check.disagreement.rotation_deg > rotation_deg);
  }
};

// Compares the ground-truth relative motion of two frames (camera-to-world
// poses) with the motion their depth images show, aligning from the GT motion.
MotionCheck checkMotion(const cv::Mat& from_depth, const Pose& from_pose, const cv::Mat& to_depth,
                        const Pose& to_pose, const CameraIntrinsics& camera,
                        const DepthAlignmentParams& params = {});

}  // namespace relocalizer
