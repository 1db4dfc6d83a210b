#pragma once
// A check of a dataset's ground truth: the relative motion between two
// consecutive frames, measured from their depth images alone
// (core/frame_alignment.h), should match the relative motion of their
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

#include <opencv2/core.hpp>

#include "relocalizer/core/frame_alignment.h"

namespace relocalizer {

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
