#include <gtest/gtest.h>

#include "relocalizer/data/dataset.h"
#include "relocalizer/data/depth_alignment.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;

namespace {

// Two consecutive frames of a synthetic path, with Kinect depth noise and
// quantisation, at half resolution to keep the test quick.
struct FramePair {
  CameraIntrinsics camera = CameraIntrinsics::kinectDefault().scaledTo(320, 240);
  RgbdFrame from, to;
  FramePair() {
    const SyntheticRoom room(7);
    const std::vector<Pose> path = room.trajectories(120, 0).train;
    from = room.render(path[40], camera, 40);
    to = room.render(path[41], camera, 41);
  }
};

DepthAlignmentParams halfResolution() {
  DepthAlignmentParams params;
  params.stride = 2;
  params.normal_step = 2;
  return params;
}

}  // namespace

TEST(DepthAlignment, RecoversTheMotionBetweenConsecutiveFrames) {
  const FramePair pair;
  const Pose truth = pair.from.ground_truth->inverse() * *pair.to.ground_truth;
  // From the identity: the images alone give the motion.
  const DepthAlignment result =
      alignDepth(pair.from.depth, pair.to.depth, pair.camera, Pose::Identity(), halfResolution());
  ASSERT_TRUE(result.valid);
  const PoseDifference error = poseDifference(truth, result.motion);
  EXPECT_LT(error.translation, 0.003);
  EXPECT_LT(error.rotation_deg, 0.15);
  EXPECT_LT(result.final_rms, result.initial_rms);
}

TEST(DepthAlignment, ConsistentGroundTruthIsNotFlagged) {
  const FramePair pair;
  const MotionCheck check = checkMotion(pair.from.depth, *pair.from.ground_truth, pair.to.depth,
                                        *pair.to.ground_truth, pair.camera, halfResolution());
  ASSERT_TRUE(check.aligned);
  EXPECT_FALSE(MotionCheckThresholds{}.flags(check));
}

TEST(DepthAlignment, FlagsAGroundTruthJump) {
  // The reference pose of the second frame jumps 3 cm sideways and 1.5 degrees,
  // as 7-Scenes redkitchen's does between frames 121 and 122.
  const FramePair pair;
  Pose jumped = *pair.to.ground_truth;
  jumped.translation() += jumped.linear() * Eigen::Vector3d(0.03, 0.0, 0.0);
  jumped.linear() =
      jumped.linear() *
      Eigen::AngleAxisd(1.5 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const MotionCheck check = checkMotion(pair.from.depth, *pair.from.ground_truth, pair.to.depth,
                                        jumped, pair.camera, halfResolution());
  ASSERT_TRUE(check.aligned);
  EXPECT_TRUE(MotionCheckThresholds{}.flags(check));
  EXPECT_NEAR(check.disagreement.rotation_deg, 1.5, 0.2);
  EXPECT_GT(check.rms_at_ground_truth, 2.0 * check.rms_aligned);
}

TEST(DepthAlignment, TooLittleDepthIsNotValid) {
  const CameraIntrinsics camera = CameraIntrinsics::kinectDefault().scaledTo(64, 48);
  const cv::Mat empty(48, 64, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  EXPECT_FALSE(alignDepth(empty, empty, camera, Pose::Identity()).valid);
}

TEST(DepthAlignment, RedkitchenGroundTruthJumpsBetweenFrames121And122) {
  RELOCALIZER_REQUIRE_REDKITCHEN(dir);
  DatasetOptions options;
  options.frames = "120-122";
  options.register_colour = false;
  auto dataset = openDataset(dir, options);
  ASSERT_TRUE(dataset.ok()) << dataset.error();
  std::vector<RgbdFrame> frames;
  for (size_t i = 0; i < (*dataset)->size(); ++i) frames.push_back(*(*dataset)->load(i));
  const MotionCheckThresholds thresholds;
  const MotionCheck before = checkMotion(frames[0].depth, *frames[0].ground_truth, frames[1].depth,
                                         *frames[1].ground_truth, frames[0].camera);
  const MotionCheck jump = checkMotion(frames[1].depth, *frames[1].ground_truth, frames[2].depth,
                                       *frames[2].ground_truth, frames[1].camera);
  EXPECT_FALSE(thresholds.flags(before));
  EXPECT_TRUE(thresholds.flags(jump));
  EXPECT_GT(jump.disagreement.translation, 0.025);
}
