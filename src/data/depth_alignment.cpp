#include "relocalizer/data/depth_alignment.h"

namespace relocalizer {

MotionCheck checkMotion(const cv::Mat& from_depth, const Pose& from_pose, const cv::Mat& to_depth,
                        const Pose& to_pose, const CameraIntrinsics& camera,
                        const DepthAlignmentParams& params) {
  MotionCheck check;
  Pose from = from_pose, to = to_pose;
  from.linear() = nearestRotation(from.linear());
  to.linear() = nearestRotation(to.linear());
  const Pose ground_truth = from.inverse() * to;  // `to` camera -> `from` camera
  check.ground_truth_motion = poseDifference(Pose::Identity(), ground_truth);
  const DepthAlignment alignment = alignDepth(from_depth, to_depth, camera, ground_truth, params);
  check.aligned = alignment.valid;
  check.rms_at_ground_truth = alignment.initial_rms;
  if (!alignment.valid) return check;
  check.rms_aligned = alignment.final_rms;
  check.depth_motion = poseDifference(Pose::Identity(), alignment.motion);
  check.disagreement = poseDifference(ground_truth, alignment.motion);
  return check;
}

}  // namespace relocalizer
