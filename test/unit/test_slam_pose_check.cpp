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
#include "relocalizer/eval/metrics.h"

#include "relocalizer/online/key_frame_feed.h"
#include "relocalizer/online/learned_places.h"
#include "relocalizer/online/submap_learner.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;

namespace {

const CameraIntrinsics kCamera = CameraIntrinsics::kinectDefault().scaledTo(320, 240);
constexpr double kFrameRate = 30.0;

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
  // Held-out frames relocalized by `relocalize`; wrong: off by more than 10
  // cm / 10 deg from the frame's pose in the map `to_map` takes the ground
  // truth's frame to.
  template <typename Relocalize>
  static Answers answer(const Relocalize& relocalize, const Pose& to_map = Pose::Identity()) {
    Answers a;
    for (const RgbdFrame& frame : test_) {
      const Relocalization r = relocalize(frame);
      if (!r.success) {
        ++a.none;
        continue;
      }
      const Pose truth = to_map * *frame.ground_truth;
      const double metres = translationError(r.pose, truth);
      a.worst_metres = std::max(a.worst_metres, metres);
      if (wrongAnswer(frameError(frame.id, r.pose, truth)))
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
  int learned_from = 0;  // of `learned`, walk frames from feedOne's `from` on
};

// The walk through the feed as the node, evaluate and learn_benchmark use it,
// into either learner; the learner retrains at the walk's middle (the place
// then answers the check's questions) and at its end.
template <typename Pose_>
Fed feedOne(KeyFrameFeed& feed, const std::vector<RgbdFrame>& walk, const Pose_& slam,
            size_t from = 0) {
  Fed fed;
  for (size_t i = 0; i < walk.size(); ++i) {
    const KeyFrameFeed::Result r = feed.offer(slam(i), [&] { return walk[i]; });
    EXPECT_NE(r.outcome, KeyFrameFeed::Result::Outcome::Failed) << r.why;
    fed.learned += r.outcome == KeyFrameFeed::Result::Outcome::Learned;
    fed.learned_from += i >= from && r.outcome == KeyFrameFeed::Result::Outcome::Learned;
    fed.refused += r.outcome == KeyFrameFeed::Result::Outcome::Refused;
    if (i + 1 == walk.size() / 2 || i + 1 == walk.size()) {
      EXPECT_TRUE(feed.learner().drain());
    }
  }
  return fed;
}

// `models` of a submap learner, searched as the node searches its learned places.
Relocalization acrossSubmaps(const std::vector<SubmapModel>& models, const RgbdFrame& frame) {
  PlaceSet places;
  EXPECT_TRUE(putLearnedPlaces(places, models, {"learned", "map"}));
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

// Jumps back and forth never hold together for a second: the submap learner,
// which could start a new place, is not asked to, and learns the walk as one.
TEST_F(LyingSlam, JumpingTfStartsNoNewPlace) {
  SubmapLearner submaps(learning(true), SubmapParams{},
                        relocalizer::testing::onlineRoomRelocalizer());
  KeyFrameFeed feed(submaps, learning(true));
  const Fed fed = feedOne(feed, walk_, jumping);
  const SlamCheckStatus status = feed.check().status();
  EXPECT_GE(fed.refused, static_cast<int>(walk_.size() / kJumpFrames / 2));
  EXPECT_EQ(status.map_moves, 0);
  EXPECT_EQ(status.new_places, 0);
  EXPECT_EQ(submaps.index().firstOfPlace(), 0);
  const std::vector<SubmapModel> models = submaps.models();
  const Answers a = answer([&](const RgbdFrame& f) { return acrossSubmaps(models, f); });
  EXPECT_EQ(a.wrong, 0);
  EXPECT_GE(a.right, static_cast<int>(test_.size()) / 2);
}

// The node's path: submaps fed through the same feed, the place asked across
// them. The room is walked once, then SLAM resets its map (the camera at the
// new origin) and the walk goes round twice more in the new map. After the
// reset SLAM's map is another one: it is learned as a new place beside the old
// (never into it), and the held-out frames are judged in the new map's
// coordinates, which are what SLAM, and so whoever uses the answers, now speaks.
TEST_F(LyingSlam, AMapResetIsLearnedAsANewPlaceNeverIntoTheOld) {
  const size_t loop = walk_.size(), at = loop;
  std::vector<RgbdFrame> walk;
  for (size_t i = 0; i < 3 * loop; ++i) {
    walk.push_back(walk_[i % loop]);  // the images shared, not copied
    walk.back().stamp = static_cast<double>(i) / kFrameRate;
  }
  ASSERT_GT(walk_[loop - 1].ground_truth->translation().norm(), 1.0);  // a reset is a jump here
  const Pose new_map = walk_[0].ground_truth->inverse();
  const auto reset = [&](size_t i) {
    const Pose truth = *walk_[i % loop].ground_truth;
    return i < at ? truth : new_map * truth;
  };
  struct Run {
    Fed fed;
    Answers all, new_place,
        old_place;  // the new place's and all in the new map, the old in the old
    SlamCheckStatus status;
    int first_new = 0, new_keyframes = 0;
  };
  const auto run = [&](bool check) {
    SubmapLearner submaps(learning(check), SubmapParams{},
                          relocalizer::testing::onlineRoomRelocalizer());
    KeyFrameFeed feed(submaps, learning(check));
    Run r;
    r.fed = feedOne(feed, walk, reset, at);
    const std::vector<SubmapModel> all = submaps.models(), current = submaps.models(true);
    std::vector<SubmapModel> old;
    for (const SubmapModel& m : all)
      if (m.index < submaps.index().firstOfPlace()) old.push_back(m);
    const auto across = [](const std::vector<SubmapModel>& models) {
      return [&models](const RgbdFrame& f) { return acrossSubmaps(models, f); };
    };
    r.all = answer(across(all), new_map);
    r.new_place = answer(across(current), new_map);
    if (!old.empty()) r.old_place = answer(across(old));
    r.status = feed.check().status();
    r.first_new = submaps.index().firstOfPlace();
    for (int s = r.first_new; s < submaps.index().submapCount(); ++s)
      r.new_keyframes += static_cast<int>(submaps.index().keyFrames(s).size());
    std::printf(
        "map reset at frame %zu of %zu, check %s: %d key frames learned (%d after the reset), %d "
        "refused, %d submaps (new place from %d); held-out, in the new map: all submaps %d "
        "right, %d wrong (> 10 cm / 10 deg, worst %.2f m), %d no pose; the new place alone %d "
        "right, %d wrong; in the old map, the old place alone: %d right, %d wrong\n",
        at, walk.size(), check ? "on" : "off", r.fed.learned, r.fed.learned_from, r.fed.refused,
        submaps.index().submapCount(), r.first_new, r.all.right, r.all.wrong, r.all.worst_metres,
        r.all.none, r.new_place.right, r.new_place.wrong, r.old_place.right, r.old_place.wrong);
    return r;
  };
  const Run after = run(true);
  // Refused until the new map held together for a second, then learned on.
  EXPECT_EQ(after.status.map_moves, 1);
  EXPECT_EQ(after.status.new_places, 1);
  EXPECT_FALSE(after.status.map_moved);  // learning did not stop
  EXPECT_NE(after.status.map_moved_why.find("new place"), std::string::npos);
  EXPECT_GE(after.fed.refused, kMapMovedKeyFrames - 1);
  EXPECT_GT(after.fed.learned_from, after.fed.learned / 2);
  // The new place holds the key frames learned after the reset and nothing
  // of the old (no seeds).
  EXPECT_GT(after.first_new, 0);
  EXPECT_EQ(after.new_keyframes, after.fed.learned_from);
  // No answer metres off in the map SLAM now has; each place alone is right.
  EXPECT_EQ(after.all.wrong, 0);
  EXPECT_EQ(after.new_place.wrong, 0);
  EXPECT_GE(after.new_place.right, static_cast<int>(test_.size()) / 2);
  EXPECT_EQ(after.old_place.wrong, 0);
  EXPECT_GE(after.old_place.right, static_cast<int>(test_.size()) / 2);
  // Without the check the reset is learned into the old place.
  const Run before = run(false);
  EXPECT_EQ(before.fed.refused, 0);
  EXPECT_GT(before.all.wrong, 0);
}

// One store holds one model: it cannot learn the new map beside the old, so
// learning into it stops, loudly, and the old place still answers right in
// its own map.
TEST_F(LyingSlam, AMapResetStopsOneStoreLearningLoudly) {
  const size_t at = walk_.size() / 2 + 4;
  OnlineLearner learner(learning(true), relocalizer::testing::onlineRoomRelocalizer(),
                        OnlineLearner::Mode::Inline);
  KeyFrameFeed feed(learner, learning(true));
  const auto slam = [&](size_t i) { return resetAt(i, at); };
  const Fed fed = feedOne(feed, walk_, slam, at);
  const SlamCheckStatus status = feed.check().status();
  EXPECT_EQ(fed.learned_from, 0);
  EXPECT_EQ(fed.refused, static_cast<int>(walk_.size() - at));
  EXPECT_TRUE(status.map_moved);
  EXPECT_EQ(status.map_moves, 1);
  EXPECT_EQ(status.new_places, 0);
  EXPECT_NE(status.map_moved_why.find("stopped"), std::string::npos) << status.map_moved_why;
  const auto place = learner.current();
  ASSERT_TRUE(place);
  const Answers a = answer([&](const RgbdFrame& f) { return place->relocalize(f); });
  EXPECT_EQ(a.wrong, 0);
  EXPECT_GT(a.right, 0);
}
