// Learn mode against SLAM that lies (issue 38, D2): a generated room walked at
// 30 Hz, every frame offered to the learning feed with a SLAM pose that jumps
// metres for a few frames at a time, or resets to the origin mid-walk. The
// check (online/slam_pose_check.h) refuses and counts what the images
// contradict, and held-out frames relocalized by the learned place come out
// right or "no pose", never metres off. Each walk is also learned with the
// check off, as learning was before it: the same frames then come out metres
// off, which is what the attack found.

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>

#include "relocalizer/core/statistics.h"

#include "relocalizer/online/key_frame_feed.h"
#include "relocalizer/online/learned_places.h"
#include "relocalizer/online/submap_learner.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;

namespace {

const CameraIntrinsics kCamera = CameraIntrinsics::kinectDefault().scaledTo(320, 240);
constexpr double kFrameRate = 30.0;

// Metres off a 10 cm / 10 deg answer may be: beyond it an answer is wrong.
constexpr double kWrongMetres = 0.10;
constexpr double kWrongDegrees = 10.0;

class LyingSlam : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const SyntheticRoom room(7);
    const SyntheticTrajectories paths = room.trajectories(80, 20);
    for (size_t i = 0; i < paths.train.size(); ++i) {
      RgbdFrame frame = room.render(paths.train[i], kCamera, static_cast<int>(i));
      frame.stamp = static_cast<double>(i) / kFrameRate;
      walk_.push_back(std::move(frame));
    }
    for (size_t i = 0; i < paths.test.size(); ++i)
      test_.push_back(room.render(paths.test[i], kCamera, static_cast<int>(100 + i)));
  }
  static void TearDownTestSuite() {
    walk_.clear();
    test_.clear();
  }

  // SLAM's pose of walk frame i when its TF jumps back and forth: every
  // other run of JUMP frames is 2.5 m off (the same way each time, so the
  // jumped frames make a second copy of the room).
  static Pose jumping(size_t i) {
    Pose pose = *walk_[i].ground_truth;
    if ((i / kJumpFrames) % 2 == 0) return pose;
    pose.translation() += Eigen::Vector3d(2.5, 0.0, 0.0);
    return pose;
  }
  static constexpr size_t kJumpFrames = 5;
  // SLAM's pose when its map resets at walk frame `at`: the camera is then at
  // the origin, and everything after is relative to it.
  static Pose resetAt(size_t i, size_t at) {
    if (i < at) return *walk_[i].ground_truth;
    return walk_[at].ground_truth->inverse() * *walk_[i].ground_truth;
  }

  struct Answers {
    int right = 0, wrong = 0, none = 0;
    double worst_metres = 0.0;
  };
  // Held-out frames relocalized by `relocalize`; wrong: off by more than 10 cm / 10 deg.
  template <typename Relocalize>
  static Answers answer(const Relocalize& relocalize) {
    Answers a;
    for (const RgbdFrame& frame : test_) {
      const Relocalization r = relocalize(frame);
      if (!r.success) {
        ++a.none;
        continue;
      }
      const double metres = translationError(r.pose, *frame.ground_truth);
      a.worst_metres = std::max(a.worst_metres, metres);
      if (metres > kWrongMetres ||
          rotationErrorDegrees(r.pose, *frame.ground_truth) > kWrongDegrees)
        ++a.wrong;
      else
        ++a.right;
    }
    return a;
  }

  static std::vector<RgbdFrame> walk_, test_;
};
std::vector<RgbdFrame> LyingSlam::walk_, LyingSlam::test_;

LearningParams learning(bool check) {
  LearningParams p = relocalizer::testing::onlineRoomLearning();
  p.slam_check.enabled = check;
  return p;
}

struct Fed {
  int learned = 0, refused = 0;
};

// The walk through the feed as the node, evaluate and learn_benchmark use it,
// into either learner; the learner retrains at the walk's middle (the place
// then answers the check's questions) and at its end.
template <typename Pose_>
Fed feedOne(KeyFrameFeed& feed, const std::vector<RgbdFrame>& walk, const Pose_& slam) {
  Fed fed;
  for (size_t i = 0; i < walk.size(); ++i) {
    const KeyFrameFeed::Result r = feed.offer(slam(i), [&] { return walk[i]; });
    EXPECT_NE(r.outcome, KeyFrameFeed::Result::Outcome::Failed) << r.why;
    fed.learned += r.outcome == KeyFrameFeed::Result::Outcome::Learned;
    fed.refused += r.outcome == KeyFrameFeed::Result::Outcome::Refused;
    if (i + 1 == walk.size() / 2 || i + 1 == walk.size()) {
      EXPECT_TRUE(feed.learner().drain());
    }
  }
  return fed;
}

Relocalization acrossSubmaps(const SubmapLearner& submaps, const RgbdFrame& frame) {
  PlaceSet places;
  EXPECT_TRUE(putLearnedPlaces(places, submaps.models(), {"learned", "map"}));
  return places.relocalize(frame).relocalization;
}

}  // namespace

TEST(SlamCheckBounds, ReadAsTextAndCheckedByName) {
  SlamCheckParams p;
  ASSERT_TRUE(readSlamCheckBounds("2,90", "0.1,3", p));
  EXPECT_EQ(p.max_speed, 2.0);
  EXPECT_EQ(p.max_turn, 90.0);
  EXPECT_EQ(p.max_disagreement_metres, 0.1);
  EXPECT_EQ(p.max_disagreement_degrees, 3.0);
  const SettingName name = [](const std::string& field) { return "~learn_" + field; };
  const Status one = readSlamCheckBounds("2", "0.1,3", p, name);
  ASSERT_FALSE(one);
  EXPECT_NE(one.error().find("~learn_max_slam_speed: '2'"), std::string::npos) << one.error();
  const Status zero = readSlamCheckBounds("2,90", "0,3", p, name);
  ASSERT_FALSE(zero);
  EXPECT_NE(zero.error().find("~learn_slam_disagreement"), std::string::npos) << zero.error();
  LearningParams learning;
  learning.slam_check.max_speed = -1;
  EXPECT_NE(learningParamsError(learning).find("max_slam_speed"), std::string::npos);
}

// A true walk loses nothing to the check.
TEST_F(LyingSlam, ATrueWalkIsLearnedWhole) {
  OnlineLearner checked_learner(learning(true), relocalizer::testing::onlineRoomRelocalizer(),
                                OnlineLearner::Mode::Inline);
  OnlineLearner unchecked_learner(learning(false), relocalizer::testing::onlineRoomRelocalizer(),
                                  OnlineLearner::Mode::Inline);
  KeyFrameFeed checked(checked_learner, learning(true));
  KeyFrameFeed unchecked(unchecked_learner, learning(false));
  const auto truth = [](size_t i) { return *walk_[i].ground_truth; };
  const Fed with = feedOne(checked, walk_, truth);
  const Fed without = feedOne(unchecked, walk_, truth);
  EXPECT_EQ(with.refused, 0) << checked.check().status().last_refusal;
  EXPECT_EQ(with.learned, without.learned);
  const SlamCheckStatus status = checked.check().status();
  EXPECT_EQ(status.checked, with.learned - 1);
  EXPECT_FALSE(status.map_moved);
  // What the check costs a key frame, alone (the depth alignment; no place is asked).
  SlamPoseCheck alone;
  KeyFrameSelector rule(KeyFrameMotion{});
  std::vector<double> milliseconds;
  for (const RgbdFrame& frame : walk_) {
    if (!rule.keep(*frame.ground_truth)) continue;
    const auto start = std::chrono::steady_clock::now();
    EXPECT_EQ(alone.check(frame, *frame.ground_truth), "");
    milliseconds.push_back(
        1000.0 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::printf("check of a %dx%d key frame: median %.2f ms, p95 %.2f ms (%zu key frames)\n",
              kCamera.width, kCamera.height, median(milliseconds), percentile(milliseconds, 95.0),
              milliseconds.size());
}

TEST_F(LyingSlam, JumpingTfIsRefusedAndNoAnswerIsMetresOff) {
  const auto run = [&](bool check) {
    OnlineLearner learner(learning(check), relocalizer::testing::onlineRoomRelocalizer(),
                          OnlineLearner::Mode::Inline);
    KeyFrameFeed feed(learner, learning(check));
    const Fed fed = feedOne(feed, walk_, jumping);
    const auto place = learner.current();
    EXPECT_TRUE(place);
    const Answers a = answer([&](const RgbdFrame& f) { return place->relocalize(f); });
    std::printf(
        "jumping TF, check %s: %d key frames learned, %d refused; held-out: %d right, %d wrong "
        "(> 10 cm / 10 deg, worst %.2f m), %d no pose\n",
        check ? "on" : "off", fed.learned, fed.refused, a.right, a.wrong, a.worst_metres, a.none);
    return std::make_tuple(fed, a, feed.check().status());
  };
  const auto [fed, answers, status] = run(true);
  EXPECT_GE(fed.refused, static_cast<int>(walk_.size() / kJumpFrames / 2));  // one a jump at least
  EXPECT_EQ(status.refused, fed.refused);
  EXPECT_NE(status.last_refusal.find("SLAM moved the camera"), std::string::npos)
      << status.last_refusal;
  EXPECT_EQ(status.map_moves, 0);  // jumps of a sixth of a second are not a new map
  EXPECT_EQ(answers.wrong, 0);
  EXPECT_GE(answers.right, static_cast<int>(test_.size()) / 2);
  // Before the check: the jumps are learned and answers come out metres off.
  const auto [fed_before, answers_before, status_before] = run(false);
  EXPECT_EQ(fed_before.refused, 0);
  EXPECT_GT(answers_before.wrong, 0);
  EXPECT_GT(answers_before.worst_metres, 1.0);
}

// The node's path: submaps fed through the same feed, the place asked across them.
TEST_F(LyingSlam, AMapResetStopsLearningIntoThePlaceLoudly) {
  const size_t at = walk_.size() / 2 + 4;
  ASSERT_GT(walk_[at].ground_truth->translation().norm(), 1.0);  // a reset is a jump here
  const auto reset = [&](size_t i) { return resetAt(i, at); };
  const auto run = [&](bool check) {
    SubmapLearner submaps(learning(check), SubmapParams{},
                          relocalizer::testing::onlineRoomRelocalizer());
    KeyFrameFeed feed(submaps, learning(check));
    const Fed fed = feedOne(feed, walk_, reset);
    const Answers a = answer([&](const RgbdFrame& f) { return acrossSubmaps(submaps, f); });
    std::printf(
        "map reset at frame %zu, check %s: %d key frames learned, %d refused; held-out: %d "
        "right, %d wrong (> 10 cm / 10 deg, worst %.2f m), %d no pose\n",
        at, check ? "on" : "off", fed.learned, fed.refused, a.right, a.wrong, a.worst_metres,
        a.none);
    return std::make_tuple(fed, a, feed.check().status());
  };
  const auto [fed, answers, status] = run(true);
  // Every frame after the reset is a key frame by motion, and each is refused.
  EXPECT_EQ(fed.refused, static_cast<int>(walk_.size() - at));
  EXPECT_TRUE(status.map_moved);
  EXPECT_EQ(status.map_moves, 1);
  EXPECT_NE(status.map_moved_why.find("SLAM's map moved"), std::string::npos);
  EXPECT_NE(status.map_moved_why.find("stopped"), std::string::npos);
  EXPECT_EQ(answers.wrong, 0);
  EXPECT_GT(answers.right, 0);
  const auto [fed_before, answers_before, status_before] = run(false);
  EXPECT_EQ(fed_before.refused, 0);
  EXPECT_GT(answers_before.wrong, 0);
}
