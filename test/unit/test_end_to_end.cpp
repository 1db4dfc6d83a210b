// The whole method on a generated room with exact ground truth: forests trained
// on one camera path, relocalization of frames from another.

#include <gtest/gtest.h>

#include "relocalizer/eval/metrics.h"
#include "relocalizer/forest/training.h"
#include "relocalizer/pose/relocalizer.h"
#include "relocalizer/sim/synthetic_scene.h"

using namespace relocalizer;

namespace {

// Small enough for CI (about half a minute on 2 cores), large enough to be a
// real relocalization problem: 320x240, 80 training frames along one loop,
// 30 test frames along another.
class SyntheticRoomRelocalization : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const SyntheticRoom room(7);
    const CameraIntrinsics camera = CameraIntrinsics::kinectDefault().scaledTo(320, 240);
    const SyntheticTrajectories paths = room.trajectories(80, 30);
    std::vector<TrainingImage> images;
    for (size_t i = 0; i < paths.train.size(); ++i)
      appendTrainingImage(room.render(paths.train[i], camera, static_cast<int>(i)), images);
    for (size_t i = 0; i < paths.test.size(); ++i)
      test_frames_.push_back(room.render(paths.test[i], camera, static_cast<int>(80 + i)));

    TrainingParams params;
    for (ForestParams* f : {&params.points, &params.lines}) {
      f->trees = 3;
      f->max_depth = 16;
      f->samples_per_image = 1000;
    }
    Model model;
    model.params = params;
    trainForests(images, params, model.points, model.lines);
    RelocalizerParams reloc;
    reloc.point_samples = 1000;
    reloc.line_samples = 500;
    reloc.solver.hypotheses = 256;
    relocalizer_ = new Relocalizer(std::move(model), reloc);
  }
  static void TearDownTestSuite() {
    delete relocalizer_;
    relocalizer_ = nullptr;
    test_frames_.clear();
  }
  static Relocalizer* relocalizer_;
  static std::vector<RgbdFrame> test_frames_;
};

Relocalizer* SyntheticRoomRelocalization::relocalizer_ = nullptr;
std::vector<RgbdFrame> SyntheticRoomRelocalization::test_frames_;

}  // namespace

// Threshold 25% per forest: RANSAC draws three correspondences per hypothesis,
// so an inlier share w gives all-inlier hypotheses with probability w^3; at
// 25% about 4 of 256 hypotheses are clean, enough for preemptive RANSAC to
// find one. A forest that learnt nothing would land within 10 cm of the truth
// in under 0.1% of samples (the room holds ~85 m^3). We measured 33% (points)
// and 51% (lines) at this scale.
TEST_F(SyntheticRoomRelocalization, ForestPredictionsLandNearTheTruthOnHeldOutFrames) {
  for (bool lines : {false, true}) {
    long samples = 0, within = 0, any = 0;
    for (const RgbdFrame& frame : test_frames_) {
      auto q = relocalizer_->measurePredictions(frame, lines, 0.10f);
      ASSERT_TRUE(q.ok()) << q.error();
      samples += q->samples;
      within += q->chosen_within;
      any += q->any_within;
    }
    ASSERT_GT(samples, 1000);
    const double share = static_cast<double>(within) / samples;
    EXPECT_GT(share, 0.25) << (lines ? "line" : "point") << " forest";
    EXPECT_GE(any, within);  // some candidate is at least as good as the chosen one
    std::printf("%s forest: %.1f%% of %ld predictions within 10 cm (%.1f%% with some candidate)\n",
                lines ? "line" : "point", 100.0 * share, samples, 100.0 * any / samples);
  }
}

TEST_F(SyntheticRoomRelocalization, NinetyPercentOfTestFramesWithinFiveCentimetresFiveDegrees) {
  std::vector<FrameError> errors;
  std::vector<std::optional<Pose>> estimates;
  std::vector<Pose> truths;
  for (const RgbdFrame& frame : test_frames_) {
    const Relocalization r = relocalizer_->relocalize(frame);
    std::optional<Pose> estimate;
    if (r.success) estimate = r.pose;
    errors.push_back(frameError(frame.id, estimate, *frame.ground_truth));
    estimates.push_back(estimate);
    truths.push_back(*frame.ground_truth);
    if (r.success) {
      EXPECT_GT(r.point_inliers, 0);
      EXPECT_GT(r.covariance.diagonal().minCoeff(), 0.0);
      EXPECT_GT(r.timings.total, 0.0);
    }
  }
  const AccuracySummary s = summarizeAccuracy(errors, estimates, truths);
  std::printf("synthetic room: %.1f%% within 5 cm / 5 deg, median %.2f cm / %.2f deg\n",
              100 * s.within_5cm_5deg, 100 * s.median_translation_m, s.median_rotation_deg);
  EXPECT_GE(s.within_5cm_5deg, 0.90);
  EXPECT_LT(s.median_translation_m, 0.02);
}

TEST_F(SyntheticRoomRelocalization, SameFrameSameAnswer) {
  const Relocalization a = relocalizer_->relocalize(test_frames_[3]);
  const Relocalization b = relocalizer_->relocalize(test_frames_[3]);
  ASSERT_EQ(a.success, b.success);
  EXPECT_TRUE(a.pose.isApprox(b.pose, 1e-12));
  EXPECT_EQ(a.point_inliers, b.point_inliers);
}

TEST_F(SyntheticRoomRelocalization, BadFramesAreExplicitFailures) {
  RgbdFrame frame = test_frames_[0];
  frame.depth.setTo(std::numeric_limits<float>::quiet_NaN());
  Relocalization r = relocalizer_->relocalize(frame);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("too little valid depth"), std::string::npos) << r.message;

  frame = test_frames_[0];
  frame.colour = cv::Mat(100, 100, CV_8UC3);
  r = relocalizer_->relocalize(frame);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("invalid frame"), std::string::npos) << r.message;
}
