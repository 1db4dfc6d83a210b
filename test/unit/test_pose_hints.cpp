// Pose hints: in a world symmetric under a 180-degree turn, a frame fits two
// places equally well and the hint decides; where the evidence is
// unambiguous a wrong hint changes nothing, and a frame that fits nowhere
// still gets no pose.

#include <gtest/gtest.h>

#include <cmath>

#include "relocalizer/eval/metrics.h"
#include "relocalizer/eval/simulated_hints.h"
#include "relocalizer/forest/model_builder.h"
#include "relocalizer/pose/pose_hint.h"
#include "relocalizer/relocalize/place_set.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;

namespace {

constexpr int kTrainFrames = 60;
constexpr int kTestFrames = 12;

// The half-turn about a vertical axis 1 m beyond the room's +x wall: it maps
// the room onto a twin beside it, the twin's views the room's own.
Pose halfTurn(const SyntheticRoom& room) {
  const Eigen::AlignedBox3d b = room.bounds();
  const Eigen::Vector3d axis(b.max().x() + 1.0, b.center().y(), 0.0);
  return Eigen::Translation3d(axis) * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()) *
         Eigen::Translation3d(-axis);
}

// A hint at `pose` moved by 10 cm and 3 degrees, with 0.3 m and 0.2 rad
// standard deviations: what an operator who knows roughly where the camera is
// would give.
PoseHint hintNear(const Pose& pose, const std::string& frame = {}) {
  PoseHint hint;
  hint.frame = frame;
  hint.pose = Eigen::Translation3d(0.07, -0.07, 0.0) * pose *
              Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d::UnitY());
  hint.covariance.diagonal() << 0.09, 0.09, 0.09, 0.04, 0.04, 0.04;
  return hint;
}

bool at(const Relocalization& answer, const Pose& truth) {
  return answer.success && within(frameError(0, answer.pose, truth), kCorrectPose);
}

// Room 7 with a model of itself (`room`) and a model of the room and its twin
// (`twins`: every training frame a second time, posed in the twin), and room
// 8's frames, which fit neither.
class PoseHints : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const CameraIntrinsics camera = CameraIntrinsics::kinectDefault().scaledTo(320, 240);
    const TrainingParams training = relocalizer::testing::smallRoomTraining();
    const RelocalizerParams params = relocalizer::testing::smallRoomRelocalizer();
    const SyntheticRoom room(7);
    turn_ = halfTurn(room);
    const SyntheticTrajectories paths = room.trajectories(kTrainFrames, kTestFrames);
    ModelBuilder alone(training), twins(training);
    for (size_t i = 0; i < paths.train.size(); ++i) {
      RgbdFrame frame = room.render(paths.train[i], camera, static_cast<int>(i));
      alone.add(frame);
      twins.add(frame);
      frame.ground_truth = turn_ * paths.train[i];
      twins.add(frame);
    }
    for (auto [builder, out] : {std::pair{&alone, &room_}, std::pair{&twins, &twins_}}) {
      auto built = builder->build({});
      ASSERT_TRUE(built.ok()) << built.error();
      *out = std::make_shared<const Relocalizer>(std::move(*built), params);
    }
    for (size_t i = 0; i < paths.test.size(); ++i)
      frames_.push_back(room.render(paths.test[i], camera, static_cast<int>(kTrainFrames + i)));
    const SyntheticRoom other(8);
    const SyntheticTrajectories other_paths = other.trajectories(kTrainFrames, 4);
    for (size_t i = 0; i < other_paths.test.size(); ++i)
      elsewhere_.push_back(other.render(other_paths.test[i], camera, static_cast<int>(i)));
  }
  static void TearDownTestSuite() {
    room_.reset();
    twins_.reset();
    frames_.clear();
    elsewhere_.clear();
  }

  static Pose turn_;
  static std::shared_ptr<const Relocalizer> room_, twins_;
  static std::vector<RgbdFrame> frames_, elsewhere_;
};

Pose PoseHints::turn_;
std::shared_ptr<const Relocalizer> PoseHints::room_, PoseHints::twins_;
std::vector<RgbdFrame> PoseHints::frames_, PoseHints::elsewhere_;

}  // namespace

TEST(PoseHint, ZeroVariancesLeaveAxesFreeAndUnusableHintsAreRefused) {
  PoseHint hint;
  EXPECT_NE(poseHintError(hint).find("all zero"), std::string::npos);
  // RViz's 2D Pose Estimate: x, y and yaw.
  hint.covariance(0, 0) = hint.covariance(1, 1) = 0.25;
  hint.covariance(5, 5) = 0.0625;
  auto prior = HintPrior::make(hint);
  ASSERT_TRUE(prior.ok()) << prior.error();
  EXPECT_FALSE(prior->complete());
  // Height, roll and pitch are free; x is 2 sigma off, yaw 1 sigma.
  const Pose pose = Eigen::Translation3d(1.0, 0.0, 5.0) *
                    Eigen::AngleAxisd(0.25, Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(0.0, Eigen::Vector3d::UnitX());
  EXPECT_NEAR(prior->distanceSquared(pose), 4.0 + 1.0, 1e-9);
  EXPECT_NEAR(prior->factor(pose, 0.5), 1.0 + 0.5 * std::exp(-2.5), 1e-9);
  EXPECT_NEAR(prior->factor(Pose::Identity(), 0.5), 1.5, 1e-12);
  // A pose rolled about x is as near as one that is not.
  const Pose rolled = Pose(Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX()));
  EXPECT_NEAR(prior->distanceSquared(rolled), 0.0, 1e-12);

  PoseHint negative = hint;
  negative.covariance(2, 2) = -1.0;
  EXPECT_NE(poseHintError(negative).find("negative"), std::string::npos);
  PoseHint indefinite = hint;
  indefinite.covariance(0, 1) = indefinite.covariance(1, 0) = 1.0;
  EXPECT_NE(poseHintError(indefinite).find("positive definite"), std::string::npos);
  PoseHint skewed = hint;
  skewed.pose.linear() *= 2.0;
  EXPECT_NE(poseHintError(skewed).find("rotation"), std::string::npos);
}

TEST(SimulatedHints, EachHintIsAsFarOffAsAskedInARepeatableRandomDirection) {
  const HintNoise noise{0.25, 4.0, 0.5, 10.0};
  SimulatedHints hints(noise, "map"), again(noise, "map");
  const Pose truth = Eigen::Translation3d(1.0, -2.0, 0.5) *
                     Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized());
  Eigen::Vector3d first_shift = Eigen::Vector3d::Zero();
  for (int i = 0; i < 20; ++i) {
    const PoseHint hint = hints.around(truth);
    EXPECT_EQ(hint.frame, "map");
    EXPECT_TRUE(poseHintError(hint).empty()) << poseHintError(hint);
    const FrameError error = frameError(0, hint.pose, truth);
    EXPECT_NEAR(error.translation_m, 0.25, 1e-9);
    EXPECT_NEAR(error.rotation_deg, 4.0, 1e-6);
    EXPECT_NEAR(hint.covariance(0, 0), 0.25, 1e-12);
    EXPECT_NEAR(hint.covariance(5, 5), std::pow(10.0 * M_PI / 180.0, 2), 1e-12);
    EXPECT_TRUE(hint.pose.isApprox(again.around(truth).pose, 0.0)) << "draw " << i;
    const Eigen::Vector3d shift = hint.pose.translation() - truth.translation();
    if (i == 0)
      first_shift = shift;
    else
      EXPECT_GT((shift - first_shift).norm(), 1e-3) << "draw " << i;
  }
  EXPECT_EQ(formatHintNoise(*parseHintNoise("0.25,4,0.5,10")), formatHintNoise(noise));
  for (const char* bad :
       {"0.1,3,0.3", "0.1,3,0.3,10,1", "0.1,3,0,10", "-1,3,0.3,10", "a,3,0.3,10", "0.1,3,0.3,nan"})
    EXPECT_FALSE(parseHintNoise(bad).ok()) << bad;
}

TEST_F(PoseHints, InTheTurnedWorldTheHintDecidesWhichOfTheTwoPlacesItIs) {
  int without_hint_at_twin = 0, right = 0, twin = 0;
  for (const RgbdFrame& frame : frames_) {
    const Pose truth = *frame.ground_truth, mirrored = turn_ * truth;
    const Relocalization free = twins_->relocalize(frame);
    // The world really holds both answers: either, never anything else.
    if (free.success) {
      EXPECT_TRUE(at(free, truth) || at(free, mirrored));
    }
    without_hint_at_twin += at(free, mirrored);

    const PoseHint here = hintNear(truth), there = hintNear(mirrored);
    const Relocalization hinted_here = twins_->relocalize(frame, &here);
    const Relocalization hinted_there = twins_->relocalize(frame, &there);
    if (hinted_here.success) {
      EXPECT_TRUE(at(hinted_here, truth)) << "hint here, frame " << frame.id;
    }
    if (hinted_there.success) {
      EXPECT_TRUE(at(hinted_there, mirrored)) << "hint in the twin, frame " << frame.id;
    }
    right += at(hinted_here, truth);
    twin += at(hinted_there, mirrored);
  }
  std::printf("of %d frames: without a hint %d at the twin; hinted right %d, hinted twin %d\n",
              kTestFrames, without_hint_at_twin, right, twin);
  // Without the hint some frames land in the twin: a hint has something to decide.
  EXPECT_GE(without_hint_at_twin, 1);
  EXPECT_LE(without_hint_at_twin, kTestFrames - 1);
  EXPECT_GE(right, kTestFrames * 3 / 4);
  EXPECT_GE(twin, kTestFrames * 3 / 4);
}

TEST_F(PoseHints, AWrongHintDoesNotOverruleUnambiguousEvidence) {
  // Room 7 alone: each frame has one answer. Hints in the twin, far outside
  // the room, and in the room but turned away, must not move it.
  int correct = 0;
  for (const RgbdFrame& frame : frames_) {
    const Pose truth = *frame.ground_truth;
    const Relocalization free = room_->relocalize(frame);
    const PoseHint far = hintNear(turn_ * truth);
    const PoseHint turned =
        hintNear(truth * Pose(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY())));
    for (const PoseHint* wrong : {&far, &turned}) {
      const Relocalization hinted = room_->relocalize(frame, wrong);
      if (hinted.success) {
        EXPECT_TRUE(at(hinted, truth)) << "frame " << frame.id;
      }
      if (at(free, truth)) {
        EXPECT_TRUE(at(hinted, truth)) << "frame " << frame.id;
      }
    }
    correct += at(free, truth);
  }
  EXPECT_GE(correct, kTestFrames * 3 / 4);
}

TEST_F(PoseHints, AFrameThatFitsNowhereStillGetsNoPose) {
  // Room 8's frames against room 7's model, hinted at the frame's own pose
  // (which names a place in room 7's coordinates too) and a pose in room 7.
  for (const RgbdFrame& frame : elsewhere_) {
    ASSERT_FALSE(room_->relocalize(frame).success) << "frame " << frame.id;
    const PoseHint own = hintNear(*frame.ground_truth);
    const PoseHint inside = hintNear(*frames_.front().ground_truth);
    for (const PoseHint* hint : {&own, &inside}) {
      const Relocalization hinted = room_->relocalize(frame, hint);
      EXPECT_FALSE(hinted.success) << "frame " << frame.id << ": " << hinted.message;
    }
  }
}

TEST_F(PoseHints, AnUnusableHintIsTheReasonForNoPose) {
  PoseHint empty;
  const Relocalization answer = room_->relocalize(frames_.front(), &empty);
  EXPECT_FALSE(answer.success);
  EXPECT_NE(answer.message.find("unusable pose hint"), std::string::npos) << answer.message;
}

TEST_F(PoseHints, WithPlacesTheHintFavoursThePlacesInItsFrame) {
  // One room under two map frames: without a hint every frame fits both alike
  // (no pose); a hint in one frame names that place, and a hint in a frame no
  // place has changes nothing.
  PlaceSet set;
  ASSERT_TRUE(set.put({"first", "first_map", "memory", room_, {}}).ok());
  ASSERT_TRUE(set.put({"second", "second_map", "memory", room_, {}}).ok());
  int first = 0, second = 0;
  for (const RgbdFrame& frame : frames_) {
    const PlaceAnswer free = set.relocalize(frame);
    EXPECT_FALSE(free.relocalization.success) << "answered by " << free.place;
    const PoseHint nowhere = hintNear(*frame.ground_truth, "elsewhere_map");
    const PlaceAnswer ignored = set.relocalize(frame, &nowhere);
    EXPECT_EQ(ignored.relocalization.success, free.relocalization.success);
    EXPECT_EQ(ignored.relocalization.message, free.relocalization.message);
    EXPECT_TRUE(ignored.relocalization.pose.isApprox(free.relocalization.pose, 0.0));

    const PoseHint in_first = hintNear(*frame.ground_truth, "first_map");
    const PoseHint in_second = hintNear(*frame.ground_truth, "second_map");
    const PlaceAnswer a = set.relocalize(frame, &in_first);
    const PlaceAnswer b = set.relocalize(frame, &in_second);
    if (a.relocalization.success) {
      EXPECT_EQ(a.place, "first");
    }
    if (b.relocalization.success) {
      EXPECT_EQ(b.place, "second");
    }
    first += a.place == "first" && at(a.relocalization, *frame.ground_truth);
    second += b.place == "second" && at(b.relocalization, *frame.ground_truth);
  }
  EXPECT_GE(first, kTestFrames * 3 / 4);
  EXPECT_GE(second, kTestFrames * 3 / 4);
}
