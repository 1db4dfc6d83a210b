// Many places in one set: each frame is answered by the room it was taken in,
// never by another, and a frame that two places explain alike gets no pose,
// unless they are parts of one map (a group) and answer the same pose.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "relocalizer/core/photometric_change.h"
#include "relocalizer/eval/evaluation.h"
#include "relocalizer/eval/metrics.h"
#include "relocalizer/forest/model_builder.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/relocalize/light_retry.h"
#include "relocalizer/relocalize/place_set.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;

namespace {

constexpr int kTrainFrames = 60;
constexpr int kTestFrames = 12;

struct Room {
  std::string name;
  std::shared_ptr<const Relocalizer> relocalizer;
  std::vector<RgbdFrame> test_frames;
};

// Two generated rooms, each with a small model trained on one camera path and
// test frames from another.
class Places : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    for (const uint64_t seed : {7, 8}) {
      const SyntheticRoom room(seed);
      const SyntheticTrajectories paths = room.trajectories(kTrainFrames, kTestFrames);
      Room r;
      r.name = "room" + std::to_string(seed);
      r.relocalizer = train(room, paths, Pose::Identity());
      ASSERT_TRUE(r.relocalizer);
      for (size_t i = 0; i < paths.test.size(); ++i)
        r.test_frames.push_back(
            room.render(paths.test[i], camera(), static_cast<int>(kTrainFrames + i)));
      rooms_.push_back(std::move(r));
    }
  }
  static void TearDownTestSuite() { rooms_.clear(); }

  // A small model of the room trained on its camera path, with every training
  // pose moved by `world_shift` (the same room, mapped into other coordinates).
  static std::shared_ptr<const Relocalizer> train(const SyntheticRoom& room,
                                                  const SyntheticTrajectories& paths,
                                                  const Pose& world_shift) {
    ModelBuilder builder(relocalizer::testing::smallRoomTraining());
    for (size_t i = 0; i < paths.train.size(); ++i) {
      RgbdFrame frame = room.render(paths.train[i], camera(), static_cast<int>(i));
      frame.ground_truth = world_shift * *frame.ground_truth;
      builder.add(std::move(frame));
    }
    auto built = builder.build({});
    EXPECT_TRUE(built.ok()) << built.error();
    if (!built) return nullptr;
    return std::make_shared<const Relocalizer>(std::move(*built),
                                               relocalizer::testing::smallRoomRelocalizer());
  }
  static CameraIntrinsics camera() { return CameraIntrinsics::kinectDefault().scaledTo(320, 240); }

  static Place placeOf(const Room& room, const std::string& name = {}) {
    return {name.empty() ? room.name : name, room.name + "_map", "memory", room.relocalizer, {}};
  }
  // Room 0's model with its evidence threshold out of reach: it screens as
  // room 0 does and never answers.
  static std::shared_ptr<const Relocalizer> blindRoom0() {
    RelocalizerParams unreachable = relocalizer::testing::smallRoomRelocalizer();
    unreachable.solver.min_inliers = 1000000;
    return std::make_shared<const Relocalizer>(rooms_[0].relocalizer->model(), unreachable);
  }
  static void putBothRooms(PlaceSet& set) {
    for (const Room& room : rooms_) EXPECT_TRUE(set.put(placeOf(room)).ok());
  }
  static std::vector<Room> rooms_;
};

std::vector<Room> Places::rooms_;

bool correct(const PlaceAnswer& answer, const RgbdFrame& frame) {
  return answer.relocalization.success &&
         within(frameError(0, answer.relocalization.pose, *frame.ground_truth), kCorrectPose);
}

}  // namespace

// In a lamp's light the place search ranks the places on a colour neither
// was trained in. Searched again in the light of the place whose training
// views the frame resembles most (light_retry.h), which is the frame's own
// room, a set of places answers more than the search answers once, each
// answer in the frame's own room; frames in the light of training are never
// searched again.
TEST_F(Places, AFrameNoPlaceAnswersInALampsLightIsSearchedAgainInTheLightOfTheViewsItResembles) {
  PlaceSet set;
  putBothRooms(set);
  const std::vector<std::shared_ptr<const Place>> places = set.places();
  // As warm as a candle, and darker: which of these frames the search once
  // loses depends on the platform's image arithmetic (with model format 5,
  // 1500 K alone lost 5 of the 24 on Debian 12 and none on Debian 11), so the
  // frames are asked in four lamps' light, 96 in all: 16 lost once on Debian 12.
  int once = 0, again = 0, searched_again = 0, frames = 0;
  for (const auto& [kelvin, stops] : {std::pair{1500.0, 0.0}, std::pair{1500.0, -1.0},
                                      std::pair{1200.0, 0.0}, std::pair{1500.0, -2.0}}) {
    PhotometricChange lamp;
    lamp.kelvin = kelvin;
    lamp.stops = stops;
    for (const Room& room : rooms_) {
      for (const RgbdFrame& recorded : room.test_frames) {
        RgbdFrame frame = recorded;
        frame.colour = applyPhotometricChange(recorded.colour, lamp);
        const PlaceAnswer first = searchPlaces(places, frame, nullptr, set.params());
        const PlaceAnswer answer = set.relocalize(frame);
        ++frames;
        std::optional<double> own_mismatch, other_mismatch;
        for (const Room& any : rooms_) {
          const auto nearest = nearestViewLight(lightGrid(frame.colour),
                                                any.relocalizer->model().summary.view_lights);
          ASSERT_TRUE(nearest) << any.name;
          (any.name == room.name ? own_mismatch : other_mismatch) = nearest->mismatch;
        }
        EXPECT_LT(*own_mismatch, *other_mismatch) << "frame " << frame.id << " of " << room.name;
        once += correct(first, frame) ? 1 : 0;
        again += correct(answer, frame) ? 1 : 0;
        EXPECT_TRUE(answer.place.empty() || answer.place == room.name)
            << "a frame of " << room.name << " in a lamp's light was answered by " << answer.place;
        if (first.relocalization.success) {
          EXPECT_EQ(answer.place, first.place);  // an answer is never searched again
        } else if (answer.relocalization.light_cast > 0.0f) {
          ++searched_again;
          if (!answer.relocalization.success) {
            EXPECT_NE(answer.relocalization.message.find("searched again in the light of"),
                      std::string::npos)
                << answer.relocalization.message;
          }
        }
        EXPECT_EQ(set.relocalize(recorded).relocalization.light_cast, 0.0f);
      }
    }
  }
  std::printf(
      "both rooms in four lamps' light: %d of %d frames right searched once, %d searched "
      "again in the light of the views each resembles (%d frames searched again)\n",
      once, frames, again, searched_again);
  EXPECT_GT(searched_again, 0);
  EXPECT_GT(again, once);
  EXPECT_GE(again, frames * 3 / 4);
}

TEST_F(Places, SharedSamplesGiveTheAnswerThePlaceGivesAlone) {
  const Relocalizer& relocalizer = *rooms_[0].relocalizer;
  for (int i : {0, 5}) {
    const RgbdFrame& frame = rooms_[0].test_frames[i];
    const Relocalization alone = relocalizer.relocalize(frame);
    auto samples = relocalizer.sample(frame);
    ASSERT_TRUE(samples.ok()) << samples.error();
    const Relocalization shared = relocalizer.relocalize(frame, *samples);
    ASSERT_EQ(alone.success, shared.success) << alone.message << " / " << shared.message;
    EXPECT_TRUE(alone.pose.isApprox(shared.pose, 1e-12));
    EXPECT_EQ(alone.point_inliers, shared.point_inliers);
    EXPECT_EQ(alone.line_inliers, shared.line_inliers);
  }
}

TEST_F(Places, EachFrameIsAnsweredByItsOwnRoomAndNeverByTheOther) {
  PlaceSet set;
  putBothRooms(set);
  for (const Room& room : rooms_) {
    int right_place = 0, correct_poses = 0, screened_first = 0;
    for (const RgbdFrame& frame : room.test_frames) {
      const PlaceAnswer answer = set.relocalize(frame);
      EXPECT_TRUE(answer.place.empty() || answer.place == room.name)
          << "a frame of " << room.name << " was answered by " << answer.place;
      right_place += answer.place == room.name ? 1 : 0;
      if (answer.place == room.name) {
        EXPECT_EQ(answer.map_frame, room.name + "_map");
      }
      correct_poses += correct(answer, frame) ? 1 : 0;
      ASSERT_EQ(answer.attempts.size(), 2u);
      screened_first += answer.attempts.front().place == room.name ? 1 : 0;
      EXPECT_GT(answer.relocalization.timings.screening, 0.0);
    }
    std::printf("%s: %d of %d frames answered by it, %d correct, screened first in %d\n",
                room.name.c_str(), right_place, kTestFrames, correct_poses, screened_first);
    EXPECT_GE(correct_poses, kTestFrames * 3 / 4) << room.name;
    EXPECT_GE(screened_first, kTestFrames * 3 / 4) << room.name;
  }
}

TEST_F(Places, AnUnloadedPlaceNeverAnswersAndItsFramesGetNoPose) {
  PlaceSet set;
  putBothRooms(set);
  ASSERT_TRUE(set.remove(rooms_[0].name));
  EXPECT_FALSE(set.remove(rooms_[0].name));
  EXPECT_EQ(set.names(), std::vector<std::string>{rooms_[1].name});
  // One place left: a frame of the removed room must not borrow the other's name.
  for (const RgbdFrame& frame : rooms_[0].test_frames) {
    const PlaceAnswer answer = set.relocalize(frame);
    EXPECT_FALSE(answer.relocalization.success) << "answered by " << answer.place;
    EXPECT_TRUE(answer.place.empty());
    EXPECT_FALSE(answer.relocalization.message.empty());
  }
  int correct_poses = 0;
  for (const RgbdFrame& frame : rooms_[1].test_frames) {
    const PlaceAnswer answer = set.relocalize(frame);
    correct_poses += correct(answer, frame) ? 1 : 0;
    if (answer.relocalization.success) {
      EXPECT_EQ(answer.place, rooms_[1].name);
    }
  }
  EXPECT_GE(correct_poses, kTestFrames * 3 / 4);
}

TEST_F(Places, TwoPlacesThatExplainAFrameAlikeGiveNoPose) {
  // The same model under two names: every frame fits both equally well, so
  // naming either would be a guess. One frame but no group: only a group says
  // that two models are parts of one map, so agreeing poses stay two answers.
  PlaceSet set;
  ASSERT_TRUE(set.put(placeOf(rooms_[0], "first")).ok());
  ASSERT_TRUE(set.put(placeOf(rooms_[0], "twin")).ok());
  int ambiguous = 0;
  for (const RgbdFrame& frame : rooms_[0].test_frames) {
    const PlaceAnswer answer = set.relocalize(frame);
    EXPECT_FALSE(answer.relocalization.success) << "answered by " << answer.place;
    ambiguous += answer.relocalization.message.find("ambiguous place") != std::string::npos;
  }
  EXPECT_GE(ambiguous, kTestFrames * 3 / 4);
}

namespace {

Place groupPlace(const std::shared_ptr<const Relocalizer>& relocalizer, const std::string& name,
                 const std::string& group, const std::string& frame = "building") {
  return {name, frame, "memory", relocalizer, group};
}

int solvedCount(const PlaceAnswer& answer) {
  int solved = 0;
  for (const PlaceAttempt& attempt : answer.attempts) solved += attempt.solved ? 1 : 0;
  return solved;
}

}  // namespace

TEST_F(Places, TheScreenPoseIsNearTheTruthWithinHalfTheScreenAgreement) {
  // What the screen skip rests on: two right screens are within
  // screen_agreement of each other when each is within half of it of the truth.
  const PlaceSearchParams params;
  for (const Room& room : rooms_) {
    int near = 0;
    for (const RgbdFrame& frame : room.test_frames) {
      auto samples = room.relocalizer->sample(frame);
      ASSERT_TRUE(samples.ok()) << samples.error();
      const ScreenResult screened = room.relocalizer->screen(*samples, params.screen);
      EXPECT_GT(screened.inliers, 0);
      near += translationError(screened.pose, *frame.ground_truth) <=
                  params.screen_agreement_metres / 2 &&
              rotationErrorDegrees(screened.pose, *frame.ground_truth) <=
                  params.screen_agreement_degrees / 2;
    }
    EXPECT_GE(near, kTestFrames * 3 / 4) << room.name;
  }
}

TEST_F(Places, TwinsInTwoFramesStayAmbiguousEvenInGroups) {
  // The same poses in two worlds are two answers, whatever the groups say.
  PlaceSet set;
  ASSERT_TRUE(set.put(groupPlace(rooms_[0].relocalizer, "first", "a", "a_map")).ok());
  ASSERT_TRUE(set.put(groupPlace(rooms_[0].relocalizer, "twin", "b", "b_map")).ok());
  int ambiguous = 0;
  for (const RgbdFrame& frame : rooms_[0].test_frames) {
    const PlaceAnswer answer = set.relocalize(frame);
    EXPECT_FALSE(answer.relocalization.success) << "answered by " << answer.place;
    ambiguous += answer.relocalization.message.find("ambiguous place") != std::string::npos;
    for (const PlaceAttempt& attempt : answer.attempts) EXPECT_FALSE(attempt.agrees);
  }
  EXPECT_GE(ambiguous, kTestFrames * 3 / 4);
}

TEST_F(Places, TwoPartsOfOneMapThatAgreeGiveThatPose) {
  // The same model twice in one group: two answers, one pose, so the answer
  // is that pose (outside a group this is "ambiguous place", above). The
  // screen skip is off: both places get the full solve.
  PlaceSearchParams params;
  params.screen_agreement_metres = -1;
  PlaceSet set(params);
  ASSERT_TRUE(set.put(groupPlace(rooms_[0].relocalizer, "kitchen/0", "kitchen")).ok());
  ASSERT_TRUE(set.put(groupPlace(rooms_[0].relocalizer, "kitchen/1", "kitchen")).ok());
  int answered = 0, correct_poses = 0;
  for (const RgbdFrame& frame : rooms_[0].test_frames) {
    const Relocalization alone = rooms_[0].relocalizer->relocalize(frame);
    const PlaceAnswer answer = set.relocalize(frame);
    ASSERT_EQ(answer.attempts.size(), 2u);
    EXPECT_EQ(solvedCount(answer), 2);
    ASSERT_EQ(answer.relocalization.success, alone.success)
        << answer.relocalization.message << " / " << alone.message;
    if (!alone.success) continue;
    ++answered;
    // Equal inliers: the first added, best screened, is the answer.
    EXPECT_EQ(answer.place, "kitchen/0");
    EXPECT_EQ(answer.map_frame, "building");
    EXPECT_TRUE(answer.relocalization.pose.isApprox(alone.pose, 1e-12));
    EXPECT_FALSE(answer.attempts[0].agrees);
    EXPECT_TRUE(answer.attempts[1].agrees);
    EXPECT_TRUE(answer.attempts[1].success);
    correct_poses += correct(answer, frame) ? 1 : 0;
  }
  EXPECT_GE(answered, kTestFrames * 3 / 4);
  EXPECT_GE(correct_poses, kTestFrames * 3 / 4);
}

TEST_F(Places, WhenTheBestPartOfAMapFailsItsNeighbourIsAsked) {
  // Two parts of one map that screen alike (one model), the first added (so
  // best screened) unable to answer: its evidence threshold is out of reach.
  // Runner-ups never count as close here (ratio above 1). Outside a group the
  // second is then not asked and the frame gets no pose; in one group it is
  // asked as the failing part's neighbour, and answers as it does alone.
  const auto blind = blindRoom0();
  PlaceSearchParams params;
  params.runner_up_ratio = 1.5f;
  PlaceSet grouped(params), apart(params);
  ASSERT_TRUE(grouped.put(groupPlace(blind, "kitchen/0", "kitchen")).ok());
  ASSERT_TRUE(grouped.put(groupPlace(rooms_[0].relocalizer, "kitchen/1", "kitchen")).ok());
  ASSERT_TRUE(apart.put(groupPlace(blind, "first", "")).ok());
  ASSERT_TRUE(apart.put(groupPlace(rooms_[0].relocalizer, "second", "")).ok());
  int answered = 0;
  for (const RgbdFrame& frame : rooms_[0].test_frames) {
    const Relocalization alone = rooms_[0].relocalizer->relocalize(frame);
    const PlaceAnswer without_group = apart.relocalize(frame);
    EXPECT_FALSE(without_group.relocalization.success);
    EXPECT_EQ(solvedCount(without_group), 1);
    const PlaceAnswer answer = grouped.relocalize(frame);
    ASSERT_EQ(answer.attempts.size(), 2u);
    EXPECT_EQ(answer.attempts[0].place, "kitchen/0");
    EXPECT_FALSE(answer.attempts[0].success);
    EXPECT_EQ(solvedCount(answer), 2);
    ASSERT_EQ(answer.relocalization.success, alone.success) << answer.relocalization.message;
    if (!alone.success) continue;
    ++answered;
    EXPECT_EQ(answer.place, "kitchen/1");
    EXPECT_TRUE(answer.relocalization.pose.isApprox(alone.pose, 1e-12));
  }
  EXPECT_GE(answered, kTestFrames * 3 / 4);
}

TEST_F(Places, WhenTheBestFailsANeighbourLeftAtItsFirstLookIsScreenedFullyAndAsked) {
  // A first look on 3 samples rarely finds a rigid set, so the part of the map
  // that can answer is mostly left at its first look with no inlier, behind
  // the failing part (added first). Once that has failed, the parts of its map
  // left at their first look are screened fully and asked by those screens: a
  // submap learned beside a survey that holds only the furniture moved since
  // had no inlier among the first look's 50 samples, and 43-61 among 200.
  const auto blind = blindRoom0();
  PlaceSearchParams params;
  params.first_look.samples = 3;
  params.rescreen_all_below = 0;  // the first looks stand, however few inliers they find
  params.runner_up_ratio = 1.5f;  // no runner-up is close: only the fallback asks
  PlaceSet grouped(params);
  ASSERT_TRUE(grouped.put(groupPlace(blind, "kitchen/0", "kitchen")).ok());
  ASSERT_TRUE(grouped.put(groupPlace(rooms_[0].relocalizer, "kitchen/1", "kitchen")).ok());
  int answered_after_an_empty_first_look = 0;
  for (const RgbdFrame& frame : rooms_[0].test_frames) {
    const Relocalization alone = rooms_[0].relocalizer->relocalize(frame);
    const Expected<FrameSamples> samples = rooms_[0].relocalizer->sample(frame);
    ASSERT_TRUE(samples.ok()) << samples.error();
    const int first_look = rooms_[0].relocalizer->screen(*samples, params.first_look).inliers;
    const PlaceAnswer answer = grouped.relocalize(frame);
    ASSERT_EQ(answer.relocalization.success, alone.success) << answer.relocalization.message;
    if (!alone.success) continue;
    EXPECT_EQ(answer.place, "kitchen/1");
    EXPECT_TRUE(answer.relocalization.pose.isApprox(alone.pose, 1e-12));
    if (first_look > 0 || answer.attempts[0].place != "kitchen/0") continue;
    ++answered_after_an_empty_first_look;
    EXPECT_FALSE(answer.attempts[0].success);
    EXPECT_TRUE(answer.attempts[1].screened_fully);
    EXPECT_GT(answer.attempts[1].screen_inliers, 0);
  }
  EXPECT_GE(answered_after_an_empty_first_look, kTestFrames / 2);
}

TEST_F(Places, AGroupRunnerUpScreenedAtTheAnswersPoseIsNotSolved) {
  // The twin screens exactly as the first: its full solve could only agree.
  PlaceSet set;
  ASSERT_TRUE(set.put(groupPlace(rooms_[0].relocalizer, "kitchen/0", "kitchen")).ok());
  ASSERT_TRUE(set.put(groupPlace(rooms_[0].relocalizer, "kitchen/1", "kitchen")).ok());
  int answered = 0;
  for (const RgbdFrame& frame : rooms_[0].test_frames) {
    const Relocalization alone = rooms_[0].relocalizer->relocalize(frame);
    const PlaceAnswer answer = set.relocalize(frame);
    ASSERT_EQ(answer.attempts.size(), 2u);
    ASSERT_EQ(answer.relocalization.success, alone.success) << answer.relocalization.message;
    if (!alone.success) {
      // Nothing answered to agree with: the twin gets its own full solve.
      EXPECT_EQ(solvedCount(answer), 2);
      continue;
    }
    ++answered;
    EXPECT_EQ(solvedCount(answer), 1);  // the node's places_solved
    EXPECT_EQ(answer.place, "kitchen/0");
    EXPECT_TRUE(answer.relocalization.pose.isApprox(alone.pose, 1e-12));
    EXPECT_FALSE(answer.attempts[1].solved);
    EXPECT_TRUE(answer.attempts[1].agrees);
  }
  EXPECT_GE(answered, kTestFrames * 3 / 4);
}

TEST_F(Places, TwoPartsOfOneMapThatDisagreeAreAmbiguousAndSayHowFarApart) {
  // The room learned twice into one map, the second time 1 m off along x: each
  // answers the frame as well as the other, at poses 1 m apart.
  const SyntheticRoom room(7);
  const SyntheticTrajectories paths = room.trajectories(kTrainFrames, kTestFrames);
  const Pose shift(Eigen::Translation3d(1.0, 0.0, 0.0));
  const std::shared_ptr<const Relocalizer> shifted = train(room, paths, shift);
  ASSERT_TRUE(shifted);
  PlaceSet set;
  ASSERT_TRUE(set.put(groupPlace(rooms_[0].relocalizer, "kitchen/0", "kitchen")).ok());
  ASSERT_TRUE(set.put(groupPlace(shifted, "kitchen/1", "kitchen")).ok());
  int ambiguous = 0;
  std::string example;
  for (const RgbdFrame& frame : rooms_[0].test_frames) {
    const Relocalization near = rooms_[0].relocalizer->relocalize(frame);
    const Relocalization far = shifted->relocalize(frame);
    const PlaceAnswer answer = set.relocalize(frame);
    const std::string& message = answer.relocalization.message;
    if (message.find("ambiguous place") == std::string::npos) continue;
    ++ambiguous;
    example = message;
    EXPECT_FALSE(answer.relocalization.success);
    EXPECT_TRUE(answer.place.empty());
    ASSERT_TRUE(near.success && far.success) << message;
    EXPECT_NE(message.find("kitchen/0"), std::string::npos) << message;
    EXPECT_NE(message.find("kitchen/1"), std::string::npos) << message;
    const double apart = translationError(near.pose, far.pose);
    EXPECT_NEAR(apart, 1.0, 0.05);
    char metres[32];
    std::snprintf(metres, sizeof metres, "%.2f m", apart);
    EXPECT_NE(message.find(metres), std::string::npos) << message << " (expected " << metres << ")";
    for (const PlaceAttempt& attempt : answer.attempts) EXPECT_FALSE(attempt.agrees);
  }
  std::printf("%d of %d frames ambiguous, the last: %s\n", ambiguous, kTestFrames, example.c_str());
  EXPECT_GE(ambiguous, kTestFrames * 3 / 4);
}

TEST_F(Places, PutGroupReplacesTheGroupAtOnce) {
  const auto& kitchen = rooms_[0].relocalizer;
  const auto& lab = rooms_[1].relocalizer;
  PlaceSet set;
  ASSERT_TRUE(set.put(Place{"lab", "building", "memory", lab, {}}).ok());
  ASSERT_TRUE(set.putGroup("kitchen", {groupPlace(kitchen, "kitchen/0", ""),
                                       groupPlace(kitchen, "kitchen/1", "")})
                  .ok());
  EXPECT_EQ(set.names(), (std::vector<std::string>{"lab", "kitchen/0", "kitchen/1"}));
  EXPECT_EQ(set.list()[1].group, "kitchen");
  EXPECT_EQ(set.list()[0].group, "");

  // kitchen/1 retrained, kitchen/2 new, kitchen/0 gone.
  ASSERT_TRUE(set.putGroup("kitchen",
                           {groupPlace(lab, "kitchen/1", ""), groupPlace(kitchen, "kitchen/2", "")})
                  .ok());
  EXPECT_EQ(set.names(), (std::vector<std::string>{"lab", "kitchen/1", "kitchen/2"}));
  EXPECT_EQ(set.places()[1]->relocalizer, lab);

  // Refused, and nothing changes.
  auto refused = [&](const std::string& group, std::vector<Place> places,
                     const std::string& reason) {
    const Status status = set.putGroup(group, std::move(places));
    ASSERT_FALSE(status.ok()) << reason;
    EXPECT_NE(status.error().find(reason), std::string::npos) << status.error();
    EXPECT_EQ(set.names(), (std::vector<std::string>{"lab", "kitchen/1", "kitchen/2"}));
  };
  refused("kitchen", {groupPlace(kitchen, "lab", "")}, "not of group kitchen");
  refused("kitchen",
          {groupPlace(kitchen, "kitchen/1", ""), groupPlace(kitchen, "kitchen/3", "", "other")},
          "a group is one map");
  refused("kitchen", {groupPlace(kitchen, "kitchen/1", ""), groupPlace(kitchen, "kitchen/1", "")},
          "given twice");
  refused("", {groupPlace(kitchen, "x", "")}, "a group needs a name");
  refused("kitchen", {groupPlace(nullptr, "kitchen/1", "")}, "no model");
  const Status elsewhere = set.put(groupPlace(kitchen, "kitchen/9", "kitchen", "other"));
  ASSERT_FALSE(elsewhere.ok());
  EXPECT_NE(elsewhere.error().find("a group is one map"), std::string::npos) << elsewhere.error();

  ASSERT_TRUE(set.putGroup("kitchen", {}).ok());
  EXPECT_EQ(set.names(), std::vector<std::string>{"lab"});

  // remove() takes one place by name, or a whole group by its name.
  ASSERT_TRUE(set.putGroup("kitchen", {groupPlace(kitchen, "kitchen/0", ""),
                                       groupPlace(kitchen, "kitchen/1", "")})
                  .ok());
  EXPECT_TRUE(set.remove("kitchen/0"));
  EXPECT_EQ(set.names(), (std::vector<std::string>{"lab", "kitchen/1"}));
  EXPECT_TRUE(set.remove("kitchen"));
  EXPECT_EQ(set.names(), std::vector<std::string>{"lab"});
  EXPECT_FALSE(set.remove("kitchen"));
}

TEST_F(Places, PutReplacesByNameAndRefusesWhatCannotBeUsed) {
  PlaceSet set;
  putBothRooms(set);
  ASSERT_EQ(set.size(), 2u);
  EXPECT_TRUE(set.put(placeOf(rooms_[1], rooms_[0].name)).ok());  // a retrained model
  EXPECT_EQ(set.size(), 2u);
  EXPECT_EQ(set.list().front().name, rooms_[0].name);

  Place unnamed = placeOf(rooms_[0], "x");
  unnamed.name.clear();
  EXPECT_FALSE(set.put(unnamed).ok());
  Place frameless = placeOf(rooms_[0], "x");
  frameless.map_frame.clear();
  const Status refused = set.put(frameless);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().find("place x"), std::string::npos) << refused.error();
  Place empty = placeOf(rooms_[0], "y");
  empty.relocalizer.reset();
  EXPECT_FALSE(set.put(empty).ok());
  EXPECT_EQ(set.size(), 2u);

  const auto missing = PlaceSet::load("lab", "/nonexistent/lab.model", "lab_map", {});
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("place lab"), std::string::npos) << missing.error();
  EXPECT_NE(missing.error().find("/nonexistent/lab.model"), std::string::npos) << missing.error();
}

// Issue 38, D1: one model file loaded twice into one frame made every frame
// "ambiguous place" until one was unloaded.
TEST_F(Places, OneModelFileTwiceInOneFrameIsRefusedNamingItsHolder) {
  const relocalizer::testing::TempDir dir;
  const std::string file = dir.str() + "/kitchen.model", copy = dir.str() + "/copy.model",
                    other = dir.str() + "/lab.model";
  ASSERT_TRUE(saveModel(rooms_[0].relocalizer->model(), file).ok());
  ASSERT_TRUE(saveModel(rooms_[0].relocalizer->model(), copy).ok());
  ASSERT_TRUE(saveModel(rooms_[1].relocalizer->model(), other).ok());
  const RelocalizerParams params = relocalizer::testing::smallRoomRelocalizer();
  const auto load = [&](const std::string& name, const std::string& path,
                        const std::string& frame = "map") {
    auto place = PlaceSet::load(name, path, frame, params);
    EXPECT_TRUE(place.ok()) << place.error();
    return std::move(*place);
  };
  PlaceSet set;
  ASSERT_TRUE(set.put(load("kitchen", file)).ok());
  for (const std::string& path : {file, copy}) {
    const Status twice = set.put(load("kitchen2", path));
    ASSERT_FALSE(twice.ok()) << path;
    EXPECT_NE(twice.error().find("already loaded as place kitchen (" + file + ") in map"),
              std::string::npos)
        << twice.error();
  }
  EXPECT_EQ(set.names(), std::vector<std::string>{"kitchen"});
  // In another frame it is another map (hints tell them apart); the place
  // itself may be loaded again (a reload); another model may share the frame.
  EXPECT_TRUE(set.put(load("kitchen2", copy, "other_map")).ok());
  EXPECT_TRUE(set.put(load("kitchen", file)).ok());
  EXPECT_TRUE(set.put(load("lab", other)).ok());
  EXPECT_FALSE(set.put(load("lab", file)).ok()) << "lab replaced by kitchen's model";
  // Nor may a group take a model a place outside it holds in its frame.
  const Status group = set.putGroup("g", {load("g/0", copy)});
  ASSERT_FALSE(group.ok());
  EXPECT_NE(group.error().find("already loaded as place kitchen"), std::string::npos)
      << group.error();
  EXPECT_EQ(set.names(), (std::vector<std::string>{"kitchen", "kitchen2", "lab"}));
}

// Issue 38, D3: a file as `h` and a folder as `h` kept `h`, `h/0`, `h/1`, and a
// file as `g/0` replaced a group's member.
TEST_F(Places, GroupAndPlaceNamesAreOneNamespace) {
  const auto& kitchen = rooms_[0].relocalizer;
  const auto& lab = rooms_[1].relocalizer;
  PlaceSet set;
  ASSERT_TRUE(set.put(Place{"h", "building", "memory", lab, {}, {}}).ok());
  const Status over_place = set.putGroup("h", {groupPlace(kitchen, "h/0", "")});
  ASSERT_FALSE(over_place.ok());
  EXPECT_NE(over_place.error().find("'h' is a place on its own"), std::string::npos)
      << over_place.error();
  ASSERT_TRUE(set.put(Place{"k/x", "building", "memory", lab, {}, {}}).ok());
  const Status over_name = set.putGroup("k", {groupPlace(kitchen, "k/0", "")});
  ASSERT_FALSE(over_name.ok());
  EXPECT_NE(over_name.error().find("place 'k/x' (on its own) is under the name 'k'"),
            std::string::npos)
      << over_name.error();
  EXPECT_EQ(set.names(), (std::vector<std::string>{"h", "k/x"}));

  ASSERT_TRUE(
      set.putGroup("g", {groupPlace(kitchen, "g/0", ""), groupPlace(kitchen, "g/1", "")}).ok());
  for (const std::string& name : {"g", "g/0", "g/7"}) {
    const Status refused = set.put(Place{name, "building", "memory", lab, {}, {}});
    ASSERT_FALSE(refused.ok()) << name;
    EXPECT_NE(refused.error().find("place " + name + ": '" + name + "' is"), std::string::npos)
        << refused.error();
  }
  EXPECT_EQ(set.places()[2]->relocalizer, kitchen) << "g/0 was replaced";
  EXPECT_EQ(set.names(), (std::vector<std::string>{"h", "k/x", "g/0", "g/1"}));
  // The group itself may be put again (a folder reloaded), and unloaded by its name.
  EXPECT_TRUE(set.putGroup("g", {groupPlace(lab, "g/0", "")}).ok());
  EXPECT_TRUE(set.remove("g"));
  EXPECT_EQ(set.names(), (std::vector<std::string>{"h", "k/x"}));
}

TEST_F(Places, FiguresDescribeTheModel) {
  const PlaceFigures figures = placeFigures(placeOf(rooms_[0]));
  EXPECT_EQ(figures.point_trees, 3);
  EXPECT_EQ(figures.line_trees, 3);
  EXPECT_GT(figures.modes, 1000);
  EXPECT_GT(figures.surface_voxels, 1000);
  EXPECT_EQ(figures.training_frames, kTrainFrames);
  EXPECT_EQ(figures.model_bytes, modelBytes(rooms_[0].relocalizer->model()));
  EXPECT_EQ(figures.map_frame, rooms_[0].name + "_map");
}

TEST_F(Places, EvaluationCountsWrongPlacesAndWritesPlacesCsv) {
  PlaceSet set;
  putBothRooms(set);
  std::vector<EvaluationRecord> records;
  for (const Room& room : rooms_)
    for (int i = 0; i < 3; ++i) {
      const RgbdFrame& frame = room.test_frames[i];
      records.push_back(recordAttempt(static_cast<int>(records.size()), 0.5 * records.size(),
                                      *frame.ground_truth, set.relocalize(frame)));
    }
  // Expecting room 7 everywhere: room 8's answered frames are wrong-place answers.
  int answered_by_other = 0;
  for (size_t i = 3; i < records.size(); ++i) answered_by_other += records[i].place.empty() ? 0 : 1;
  ASSERT_GT(answered_by_other, 0);
  const EvaluationSummary summary = summarizeEvaluation(records, rooms_[0].name);
  EXPECT_EQ(summary.wrong_place, answered_by_other);
  EXPECT_NE(formatEvaluationTable(summary, "t").find("wrong place"), std::string::npos);
  EXPECT_EQ(summarizeEvaluation(records).wrong_place, -1);

  const relocalizer::testing::TempDir dir;
  EvaluationOutputOptions options;
  options.integer_stamps = true;
  options.places = true;
  ASSERT_TRUE(writeEvaluationOutputs(dir.str(), records, summary, options).ok());
  std::ifstream csv(dir.path() / "places.csv");
  std::string line;
  std::getline(csv, line);  // the header comment
  ASSERT_EQ(line[0], '#');
  for (const EvaluationRecord& record : records) {
    ASSERT_TRUE(std::getline(csv, line));
    EXPECT_EQ(line, std::to_string(record.id) + " " + record.place);
  }
  std::ifstream json(dir.path() / "summary.json");
  std::stringstream text;
  text << json.rdbuf();
  EXPECT_NE(text.str().find("\"wrong_place\": " + std::to_string(answered_by_other)),
            std::string::npos);
}

namespace {

// A tool of this build with both its outputs in `log`.
int runLogged(const std::string& tool, const std::string& arguments, const std::string& log) {
  return relocalizer::testing::runTool(tool, arguments, log, log);
}

// Six frames of room 7 (the same seed gives the same room), written as the dataset DIR/scene.
void writeRoomSevenFrames(const relocalizer::testing::TempDir& dir) {
  ASSERT_EQ(
      runLogged("synthesize",
                "--seed 7 --train-frames 1 --test-frames 6 --width 320 --height 240 --output '" +
                    dir.str() + "/scene'",
                dir.str() + "/synthesize.log"),
      0)
      << relocalizer::testing::readBytes(dir.path() / "synthesize.log");
}

}  // namespace

TEST_F(Places, EvaluateSeesTheFramesUnderOtherLightWhenAsked) {
  const relocalizer::testing::TempDir dir;
  ASSERT_TRUE(saveModel(rooms_[0].relocalizer->model(), dir.str() + "/room.model").ok());
  writeRoomSevenFrames(dir);
  const std::string evaluate = " --model '" + dir.str() + "/room.model' --dataset '" + dir.str() +
                               "/scene/test' --output '" + dir.str() + "/out'";
  ASSERT_EQ(runLogged("evaluate", evaluate + " --light-stops -1 --light-kelvin 2700",
                      dir.str() + "/evaluate.log"),
            0)
      << relocalizer::testing::readBytes(dir.path() / "evaluate.log");
  const std::string log = relocalizer::testing::readBytes(dir.path() / "evaluate.log");
  EXPECT_NE(log.find("changed:      -1 stop, 2700 K"), std::string::npos) << log;
  EXPECT_NE(log.find("wrong (> 10 cm or 10 deg)"), std::string::npos) << log;
  const std::string summary = relocalizer::testing::readBytes(dir.path() / "out" / "summary.json");
  EXPECT_NE(summary.find("\"description\": \"-1 stop, 2700 K\""), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"wrong_answers\""), std::string::npos) << summary;
  // Out of range: refused before any frame is read, naming the option.
  EXPECT_EQ(runLogged("evaluate", evaluate + " --light-kelvin 500", dir.str() + "/bad.log"), 2);
  EXPECT_NE(relocalizer::testing::readBytes(dir.path() / "bad.log").find("--light-kelvin"),
            std::string::npos);
}

TEST_F(Places, EvaluateRelocalizesAgainstEveryModelAndNamesEachFramesPlace) {
  const relocalizer::testing::TempDir dir;
  for (const Room& room : rooms_)
    ASSERT_TRUE(saveModel(room.relocalizer->model(), dir.str() + "/" + room.name + ".model").ok());
  writeRoomSevenFrames(dir);
  const std::string models = " --model room7='" + dir.str() + "/room7.model' --model room8='" +
                             dir.str() + "/room8.model' --dataset '" + dir.str() + "/scene/test'";
  ASSERT_EQ(runLogged("evaluate", models + " --expect-place room7 --output '" + dir.str() + "/out'",
                      dir.str() + "/evaluate.log"),
            0)
      << relocalizer::testing::readBytes(dir.path() / "evaluate.log");
  const std::string log = relocalizer::testing::readBytes(dir.path() / "evaluate.log");
  EXPECT_NE(log.find("wrong place (not room7)"), std::string::npos) << log;
  std::istringstream places(relocalizer::testing::readBytes(dir.path() / "out" / "places.csv"));
  std::string line;
  std::getline(places, line);
  int rows = 0, room7 = 0;
  while (std::getline(places, line)) {
    ++rows;
    EXPECT_TRUE(line == std::to_string(rows - 1) + " room7" ||
                line == std::to_string(rows - 1) + " ")
        << line;
    room7 += line.find("room7") != std::string::npos ? 1 : 0;
  }
  EXPECT_EQ(rows, 6);
  EXPECT_GE(room7, 4);
  EXPECT_NE(relocalizer::testing::readBytes(dir.path() / "out" / "summary.json")
                .find("\"wrong_place\": 0"),
            std::string::npos);

  // One room under two names (and map frames) fits every frame alike, so no
  // frame gets a pose; a hint near the truth in the first's frame names it.
  const std::string twins = " --model first='" + dir.str() + "/room7.model' --model second='" +
                            dir.str() + "/room7.model' --dataset '" + dir.str() +
                            "/scene/test' --expect-place first";
  for (const std::string hint : {"", " --hint 0.1,3,0.3,10"}) {
    const std::string out = dir.str() + (hint.empty() ? "/twins" : "/hinted");
    ASSERT_EQ(runLogged("evaluate", twins + hint + " --output '" + out + "'", out + ".log"), 0)
        << relocalizer::testing::readBytes(out + ".log");
    std::istringstream answers(relocalizer::testing::readBytes(out + "/places.csv"));
    std::getline(answers, line);
    int first = 0, second = 0;
    while (std::getline(answers, line)) {
      first += line.find("first") != std::string::npos;
      second += line.find("second") != std::string::npos;
    }
    EXPECT_EQ(second, 0) << hint;
    if (hint.empty())
      EXPECT_EQ(first, 0);
    else
      EXPECT_GE(first, 4);
  }
  EXPECT_NE(relocalizer::testing::readBytes(dir.path() / "hinted" / "summary.json")
                .find("\"hint\": \"0.1,3,0.3,10\""),
            std::string::npos);

  // Mistakes name the option.
  EXPECT_NE(runLogged("evaluate", models + " --hint 0.1,3,0.3,10", dir.str() + "/nohome.log"), 0);
  EXPECT_NE(relocalizer::testing::readBytes(dir.path() / "nohome.log").find("--expect-place"),
            std::string::npos);
  EXPECT_NE(runLogged("evaluate", models + " --expect-place room7 --hint 0.1,3,0,10",
                      dir.str() + "/badhint.log"),
            0);
  EXPECT_NE(relocalizer::testing::readBytes(dir.path() / "badhint.log").find("bad --hint"),
            std::string::npos);
  EXPECT_NE(runLogged("evaluate", models + " --expect-place kitchen", dir.str() + "/bad.log"), 0);
  EXPECT_NE(relocalizer::testing::readBytes(dir.path() / "bad.log").find("--expect-place kitchen"),
            std::string::npos);
  EXPECT_NE(runLogged("evaluate", models + " --model room7='" + dir.str() + "/room8.model'",
                      dir.str() + "/twice.log"),
            0);
  EXPECT_NE(relocalizer::testing::readBytes(dir.path() / "twice.log").find("given twice"),
            std::string::npos)
      << relocalizer::testing::readBytes(dir.path() / "twice.log");
  // places.csv is "frame place" separated by a space: a name with one (or
  // any character no place name may hold) would make it ambiguous.
  EXPECT_EQ(runLogged("evaluate",
                      models + " --model 'bad name!=" + dir.str() + "/room8.model' --output '" +
                          dir.str() + "/badname'",
                      dir.str() + "/badname.log"),
            2);
  const std::string bad_name = relocalizer::testing::readBytes(dir.path() / "badname.log");
  EXPECT_NE(bad_name.find("--model"), std::string::npos) << bad_name;
  EXPECT_NE(bad_name.find("'bad name!'"), std::string::npos) << bad_name;
  EXPECT_NE(bad_name.find("holds a character other than"), std::string::npos) << bad_name;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "badname" / "places.csv"));
}

TEST_F(Places, AScreenThatReusesAFirstLooksPredictionsScreensAsAFreshOne) {
  // The second pass of the place screen predicts only the samples the first
  // look did not: the screen it gives must be the one a fresh screen gives.
  const PlaceSearchParams params;
  for (const Room& room : rooms_) {
    for (int i : {0, 3, 7}) {
      auto samples = room.relocalizer->sample(room.test_frames[i]);
      ASSERT_TRUE(samples.ok()) << samples.error();
      std::vector<Prediction> predicted;
      const ScreenResult first = room.relocalizer->screen(*samples, params.first_look, &predicted);
      EXPECT_EQ(predicted.size(), static_cast<size_t>(params.first_look.samples));
      const ScreenResult reused = room.relocalizer->screen(*samples, params.screen, &predicted);
      EXPECT_EQ(predicted.size(), static_cast<size_t>(params.screen.samples));
      const ScreenResult fresh = room.relocalizer->screen(*samples, params.screen);
      EXPECT_EQ(reused.inliers, fresh.inliers);
      EXPECT_TRUE(reused.pose.isApprox(fresh.pose, 1e-12));
      EXPECT_GT(first.inliers, 0) << room.name << " frame " << i;
    }
  }
}

TEST_F(Places, PointsReadySeesThePointSamplesBeforeTheLinesAreDone) {
  const Relocalizer& relocalizer = *rooms_[0].relocalizer;
  const RgbdFrame& frame = rooms_[0].test_frames[2];
  int calls = 0;
  std::vector<Eigen::Vector3f> seen;
  auto samples = relocalizer.sample(frame, [&](const FrameSamples& points) {
    ++calls;
    for (const Sample& s : points.points) seen.push_back(s.camera_point);
    EXPECT_EQ(points.point_descriptors.size(), points.points.size());
  });
  ASSERT_TRUE(samples.ok()) << samples.error();
  EXPECT_EQ(calls, 1);
  ASSERT_EQ(seen.size(), samples->points.size());
  ASSERT_FALSE(seen.empty());
  for (size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], samples->points[i].camera_point);
  EXPECT_FALSE(samples->lines.samples.empty());  // the lines were drawn all the same
  // A refused frame never reaches the callback.
  RgbdFrame refused = frame;
  refused.depth = cv::Mat();  // a new header: the shared frame keeps its depth
  EXPECT_FALSE(relocalizer.sample(refused, [&](const FrameSamples&) { ++calls; }).ok());
  EXPECT_EQ(calls, 1);
}

TEST_F(Places, TheFirstLookAnswersAsScreeningEveryPlaceFully) {
  // Two rooms, a twin of room 0 (ambiguous by design) and a part of room 0's
  // map: with the first look (the default) and without it (every place
  // screened fully), every frame gets the same answer, and the twin is
  // still screened fully and solved: look-alikes are never left at a glance.
  PlaceSearchParams without;
  without.first_look.samples = 0;
  PlaceSet looked, full(without);
  for (PlaceSet* set : {&looked, &full}) {
    ASSERT_TRUE(set->put(groupPlace(rooms_[0].relocalizer, "a/0", "a", "a_map")).ok());
    ASSERT_TRUE(set->put(groupPlace(rooms_[0].relocalizer, "a/1", "a", "a_map")).ok());
    ASSERT_TRUE(set->put(placeOf(rooms_[1])).ok());
  }
  int fewer_full_screens = 0;
  for (const Room& room : rooms_)
    for (const RgbdFrame& frame : room.test_frames) {
      const PlaceAnswer a = looked.relocalize(frame), b = full.relocalize(frame);
      EXPECT_EQ(a.place, b.place);
      EXPECT_EQ(a.relocalization.success, b.relocalization.success);
      EXPECT_EQ(a.relocalization.message, b.relocalization.message);
      if (a.relocalization.success) {
        EXPECT_TRUE(a.relocalization.pose.isApprox(b.relocalization.pose, 1e-12));
      }
      EXPECT_EQ(b.search.full_screens, 3);
      fewer_full_screens += a.search.full_screens < 3;
      for (const PlaceAttempt& attempt : b.attempts) EXPECT_TRUE(attempt.screened_fully);
    }
  // Room 1's frames: room 0's places are far at the first look.
  EXPECT_GE(fewer_full_screens, kTestFrames * 3 / 4);

  PlaceSet twins;
  ASSERT_TRUE(twins.put(placeOf(rooms_[0], "first")).ok());
  ASSERT_TRUE(twins.put(placeOf(rooms_[0], "twin")).ok());
  ASSERT_TRUE(twins.put(placeOf(rooms_[1])).ok());
  int ambiguous = 0;
  for (const RgbdFrame& frame : rooms_[0].test_frames) {
    const PlaceAnswer answer = twins.relocalize(frame);
    EXPECT_FALSE(answer.relocalization.success) << "answered by " << answer.place;
    if (answer.relocalization.message.find("ambiguous place") == std::string::npos) continue;
    ++ambiguous;
    EXPECT_EQ(answer.search.solves, 2);  // the best and its twin, side by side
    EXPECT_TRUE(answer.attempts[0].screened_fully && answer.attempts[1].screened_fully);
  }
  EXPECT_GE(ambiguous, kTestFrames * 3 / 4);
}

TEST_F(Places, AFirstLookThatCannotFeedTheFullScreenIsRefused) {
  PlaceSearchParams params;
  EXPECT_EQ(params.validationError(), "");
  params.first_look.samples = 0;  // no first look: every place screened fully
  EXPECT_EQ(params.validationError(), "");
  params.first_look.samples = params.screen.samples + 1;  // more than the screen it feeds
  EXPECT_NE(params.validationError(), "");
  params.first_look.samples = 100;
  params.first_look.max_leaves = params.screen.max_leaves + 1;  // other predictions
  EXPECT_NE(params.validationError(), "");
  params.first_look.max_leaves = params.screen.max_leaves;
  params.rescreen_ratio = 1.5f;
  EXPECT_NE(params.validationError(), "");
}
