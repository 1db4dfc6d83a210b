// The submap rule (online/submap_rule.h) on hand-made camera poses, where the
// submap every key frame belongs to is known by construction.

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "relocalizer/online/submap_rule.h"

using namespace relocalizer;

namespace {

// Camera i of a straight walk along x, 6 cm apart: 1.2 key-frame steps, so no
// two are within one step (the default cover distance) and none is on its edge.
Pose walkPose(int i) {
  Pose pose = Pose::Identity();
  pose.translation() = Eigen::Vector3d(0.06 * i, 0.0, 1.0);
  return pose;
}

Pose shifted(const Pose& pose, const Eigen::Vector3d& by) {
  Pose moved = pose;
  moved.translation() += by;
  return moved;
}

SubmapParams smallSubmaps() {
  SubmapParams params;
  params.overlap = 1;
  params.min_submap_keyframes = 3;
  return params;
}

std::vector<std::int64_t> ids(const std::vector<SubmapKeyFrame>& frames) {
  std::vector<std::int64_t> out;
  for (const SubmapKeyFrame& k : frames) out.push_back(k.id);
  return out;
}

using D = SubmapDecision;

}  // namespace

TEST(SubmapRule, AFullSubmapHandsItsNearestKeyFramesToTheNext) {
  SubmapIndex index(smallSubmaps(), 4);
  std::vector<D> decisions;
  std::vector<int> submaps;
  for (int i = 0; i < 10; ++i) {
    const SubmapPlacement placed = index.place(i, walkPose(i));
    decisions.push_back(placed.decision);
    submaps.push_back(placed.submap);
  }
  // Cap 4, overlap 1: each new submap starts with the last key frame of the one before.
  EXPECT_EQ(decisions, (std::vector<D>{D::Start, D::Active, D::Active, D::Active, D::NewFull,
                                       D::Active, D::Active, D::NewFull, D::Active, D::Active}));
  EXPECT_EQ(submaps, (std::vector<int>{0, 0, 0, 0, 1, 1, 1, 2, 2, 2}));
  EXPECT_EQ(index.submapCount(), 3);
  EXPECT_EQ(ids(index.keyFrames(0)), (std::vector<std::int64_t>{0, 1, 2, 3}));
  EXPECT_EQ(ids(index.keyFrames(1)), (std::vector<std::int64_t>{3, 4, 5, 6}));
  EXPECT_EQ(ids(index.keyFrames(2)), (std::vector<std::int64_t>{6, 7, 8, 9}));
  EXPECT_TRUE(index.frozen(0));
  EXPECT_TRUE(index.frozen(1));
  EXPECT_FALSE(index.frozen(2));
}

TEST(SubmapRule, SeedsAreTheNearestKeyFramesNearestFirst) {
  SubmapParams params = smallSubmaps();
  params.overlap = 2;
  SubmapIndex index(params, 4);
  for (int i = 0; i < 4; ++i) index.place(i, walkPose(i));
  // Back beside key frame 1, looking the same way: 1 and then 0 or 2 are nearest.
  const SubmapPlacement placed = index.place(100, shifted(walkPose(1), {0.0, 0.02, 0.0}));
  ASSERT_EQ(placed.decision, D::NewFull);
  ASSERT_EQ(placed.seeds.size(), 2u);
  EXPECT_EQ(placed.seeds[0].id, 1);
  EXPECT_TRUE(placed.seeds[1].id == 0 || placed.seeds[1].id == 2);
  EXPECT_EQ(ids(index.keyFrames(1)), (std::vector<std::int64_t>{1, placed.seeds[1].id, 100}));
}

TEST(SubmapRule, ACameraThatLeftStartsAfreshOnlyFromAGrownSubmap) {
  SubmapIndex index(smallSubmaps(), 8);
  for (int i = 0; i < 4; ++i) index.place(i, walkPose(i));
  // 5 m away from every key frame of a 4-key-frame active (minimum 3): a new submap, no seeds.
  const Pose far = shifted(walkPose(3), {0.0, 5.0, 0.0});
  SubmapPlacement placed = index.place(10, far);
  EXPECT_EQ(placed.decision, D::NewLeft);
  EXPECT_EQ(placed.submap, 1);
  EXPECT_TRUE(placed.seeds.empty());
  EXPECT_TRUE(index.frozen(0));
  // 5 m on again, but the active holds 1 key frame: it stays there.
  placed = index.place(11, shifted(far, {0.0, 5.0, 0.0}));
  EXPECT_EQ(placed.decision, D::Active);
  EXPECT_EQ(placed.submap, 1);
  placed = index.place(12, shifted(far, {0.0, 10.0, 0.0}));
  EXPECT_EQ(placed.decision, D::Active);
  // Now 3 key frames: leaving starts submap 2.
  EXPECT_EQ(index.decide(shifted(far, {0.0, 20.0, 0.0})), D::NewLeft);
  // Within 1.5 m of any of the active's key frames is inside its area.
  EXPECT_EQ(index.decide(shifted(far, {1.4, 5.0, 0.0})), D::Active);
}

TEST(SubmapRule, TheSameWalkAgainAddsNothingButATurnedCameraDoes) {
  SubmapIndex index(smallSubmaps(), 4);
  for (int i = 0; i < 10; ++i) index.place(i, walkPose(i));
  index.freezeActive();
  EXPECT_EQ(index.active(), -1);
  for (int i = 0; i < 10; ++i) {
    const SubmapPlacement again = index.place(100 + i, walkPose(i));
    EXPECT_EQ(again.decision, D::Covered) << "pose " << i;
    EXPECT_EQ(again.submap, -1);
  }
  EXPECT_EQ(index.submapCount(), 3);
  // 2 cm beside a key frame is within one step: covered. Turned 90 degrees on the
  // same spot sees another wall: a new submap starts.
  EXPECT_EQ(index.decide(shifted(walkPose(5), {0.0, 0.02, 0.0})), D::Covered);
  Pose turned = walkPose(5);
  turned.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const SubmapPlacement placed = index.place(200, turned);
  EXPECT_EQ(placed.decision, D::Start);
  EXPECT_EQ(placed.submap, 3);
}

// After SLAM's map moved (a reset puts the camera back where the old map had
// key frames), the same poses mean other places: the new map is learned from
// its first key frame into a new submap with no seeds, and the old submaps
// cover nothing of it; the new place covers itself as any place does.
TEST(SubmapRule, ANewPlaceSharesNothingWithTheSubmapsBeforeIt) {
  SubmapIndex index(smallSubmaps(), 4);
  for (int i = 0; i < 6; ++i) index.place(i, walkPose(i));  // submap 0 full, 1 active
  ASSERT_EQ(index.submapCount(), 2);
  index.startApart();
  EXPECT_EQ(index.firstOfPlace(), 2);
  // Within one step of submap 0's key frames, and within the active's area.
  EXPECT_EQ(index.decide(walkPose(1)), D::NewLeft);
  const SubmapPlacement first = index.place(100, walkPose(1));
  EXPECT_EQ(first.decision, D::NewLeft);
  EXPECT_EQ(first.submap, 2);
  EXPECT_TRUE(first.seeds.empty());
  EXPECT_EQ(ids(index.keyFrames(2)), std::vector<std::int64_t>({100}));
  for (int i = 2; i < 5; ++i) EXPECT_EQ(index.place(100 + i, walkPose(i)).submap, 2);
  EXPECT_EQ(index.place(105, walkPose(5)).decision, D::NewFull);  // the new place goes on
  EXPECT_EQ(index.firstOfPlace(), 2);
  EXPECT_EQ(index.decide(walkPose(2)), D::Covered);  // by submap 2, of the new place
}

TEST(SubmapRule, TheActiveSubmapNeverCoversSoOneSubmapLearnsAsOneStore) {
  SubmapIndex index(smallSubmaps(), 64);
  for (int i = 0; i < 5; ++i) index.place(i, walkPose(0));
  EXPECT_EQ(index.submapCount(), 1);
  EXPECT_EQ(index.keyFrames(0).size(), 5u);
}

TEST(SubmapRule, CoveringOffStoresEveryKeyFrame) {
  SubmapParams params = smallSubmaps();
  params.cover_steps = 0.0;
  SubmapIndex index(params, 4);
  for (int i = 0; i < 4; ++i) index.place(i, walkPose(i));
  index.freezeActive();
  EXPECT_EQ(index.place(10, walkPose(0)).decision, D::Start);
}

// A place that changed is learned again where a frozen submap covers it: the
// caller (which sees the images) says so, and the key frame is placed as if
// nothing covered it.
TEST(SubmapRule, ACoveredKeyFrameOfAChangedPlaceIsPlacedAsIfUncovered) {
  SubmapIndex index(smallSubmaps(), 4);
  for (int i = 0; i < 4; ++i) index.place(i, walkPose(i));
  index.freezeActive();
  EXPECT_EQ(index.coveringSubmaps(walkPose(1)), std::vector<int>{0});
  EXPECT_EQ(index.decide(walkPose(1)), D::Covered);
  const SubmapPlacement placed = index.place(10, walkPose(1), false);
  EXPECT_EQ(placed.decision, D::Start);
  EXPECT_EQ(placed.submap, 1);
  EXPECT_TRUE(index.coveringSubmaps(walkPose(1)) == std::vector<int>{0});
}

// A camera looping past a changed place relearns each view once: the active
// submap that holds it then covers it for the changed place's key frames only.
TEST(SubmapRule, AChangedViewTheActiveSubmapHoldsIsNotLearnedAgainOnTheNextLap) {
  SubmapIndex index(smallSubmaps(), 8);
  for (int i = 0; i < 4; ++i) index.place(i, walkPose(i));
  index.freezeActive();
  ASSERT_EQ(index.place(10, walkPose(1), false).submap, 1);
  ASSERT_EQ(index.place(11, walkPose(2), false).decision, D::Active);
  const SubmapPlacement again = index.place(12, walkPose(1), false);
  EXPECT_EQ(again.decision, D::Covered);
  EXPECT_EQ(again.submap, -1);
  EXPECT_EQ(index.keyFrames(1).size(), 2u);
  // Where the old submaps still agree, the active covers nothing (a run that
  // fits one submap learns as one store does), and a new view is learned.
  EXPECT_EQ(index.decide(walkPose(1)), D::Covered);
  EXPECT_TRUE(index.coveringSubmaps(walkPose(1)) == std::vector<int>{0});
  EXPECT_EQ(index.decide(walkPose(3), false), D::Active);
}

TEST(SubmapRule, UnusableSettingsAreNamed) {
  const SettingName node = [](const std::string& field) { return "~learn_" + field; };
  SubmapParams params;
  params.overlap = 16;
  EXPECT_EQ(submapParamsError(params, 16, node),
            "~learn_overlap must be between 0 and ~learn_max_keyframes - 1 (got 16)");
  EXPECT_EQ(submapParamsError(params, 17), "");
  params = SubmapParams{};
  params.area_radius = std::nan("");
  EXPECT_NE(submapParamsError(params, 16).find("area_radius must be a finite distance"),
            std::string::npos);
  params = SubmapParams{};
  params.cover_steps = -1.0;
  EXPECT_NE(submapParamsError(params, 16).find("cover_steps"), std::string::npos);
  params = SubmapParams{};
  params.relearn_agreement = 1.5;
  EXPECT_NE(submapParamsError(params, 16).find("relearn_agreement must be a share"),
            std::string::npos);
  params = SubmapParams{};
  params.min_submap_keyframes = 17;
  EXPECT_NE(submapParamsError(params, 16).find("min_submap_keyframes"), std::string::npos);
  EXPECT_THROW(SubmapIndex(params, 16), std::invalid_argument);
  EXPECT_EQ(SubmapIndex(SubmapParams{}, 16).minSubmapKeyFrames(), 4);
}

TEST(SubmapRule, ARestoredIndexDecidesAsTheOneItWasSavedFrom) {
  SubmapIndex saved(smallSubmaps(), 4);
  for (int i = 0; i < 6; ++i) saved.place(i, walkPose(i));
  // Submap 0 frozen (0-3), submap 1 active (3-5); restored with submap 0
  // empty, as a resume does with a submap it could not load.
  SubmapIndex restored(smallSubmaps(), 4);
  restored.restore({saved.keyFrames(0), saved.keyFrames(1)}, saved.active());
  SubmapIndex skipped(smallSubmaps(), 4);
  skipped.restore({{}, saved.keyFrames(1)}, 1);
  for (int i = 0; i < 8; ++i)
    EXPECT_EQ(restored.decide(walkPose(i)), saved.decide(walkPose(i))) << "pose " << i;
  EXPECT_EQ(restored.decide(walkPose(1)), D::Covered);
  EXPECT_EQ(skipped.decide(walkPose(1)), D::Active);
  EXPECT_EQ(restored.place(6, walkPose(6)).submap, 1);
  EXPECT_EQ(restored.place(7, walkPose(7)).submap, 2);                       // full: the next index
  EXPECT_EQ(ids(restored.keyFrames(2)), (std::vector<std::int64_t>{6, 7}));  // seeded with 6
  // Only into a fresh index, and only with an active that exists.
  EXPECT_THROW(restored.restore({}, -1), std::invalid_argument);
  SubmapIndex fresh(smallSubmaps(), 4);
  EXPECT_THROW(fresh.restore({{}}, 1), std::invalid_argument);
}

// A survey made by `train` holds no key-frame poses, so no pose is covered by
// it (its surface decides, place_change.h); it is listed while its place is
// the one learned, never the active submap.
TEST(SubmapRule, ASubmapWithoutKeyFramePosesIsListedAsSurveyed) {
  SubmapIndex index(smallSubmaps(), 4);
  index.restore({{}}, -1);
  EXPECT_EQ(index.surveyedSubmaps(), std::vector<int>{0});
  EXPECT_EQ(index.decide(walkPose(0)), D::Start);
  EXPECT_EQ(index.place(0, walkPose(0)).submap, 1);
  EXPECT_EQ(index.surveyedSubmaps(), std::vector<int>{0});  // the new submap holds a pose
  index.startApart();
  EXPECT_TRUE(index.surveyedSubmaps().empty());
}
