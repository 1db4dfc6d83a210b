// Changes of the world after training (SceneChanges, synthesize --test-*):
// each is checked against the unchanged room rendered from the same poses.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <vector>

#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;
namespace fs = std::filesystem;

namespace {

using relocalizer::testing::sameImage;

const CameraIntrinsics kSmall = CameraIntrinsics::kinectDefault().scaledTo(320, 240);
const CameraIntrinsics kTiny = CameraIntrinsics::kinectDefault().scaledTo(160, 120);

// Camera at `from` looking at `at`, image y down, world z up.
Pose lookAt(const Eigen::Vector3d& from, const Eigen::Vector3d& at) {
  const Eigen::Vector3d z = (at - from).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  Pose pose = Pose::Identity();
  pose.linear().col(0) = x;
  pose.linear().col(1) = z.cross(x);
  pose.linear().col(2) = z;
  pose.translation() = from;
  return pose;
}

// Eight views all round from the middle of the room at eye height, a little down.
std::vector<Pose> viewsAllRound(const SyntheticRoom& room) {
  const Eigen::Vector3d from(room.bounds().center().x(), room.bounds().center().y(), 1.3);
  std::vector<Pose> views;
  for (int h = 0; h < 8; ++h) {
    const double a = h * M_PI / 4;
    views.push_back(lookAt(from, from + Eigen::Vector3d(std::cos(a), std::sin(a), -0.25)));
  }
  return views;
}

RenderEffects exactRender() {
  RenderEffects effects;
  effects.depth_noise = false;
  return effects;
}

// Distance from p to the box (0 inside).
double boxDistance(const RoomBox& box, const Eigen::Vector3d& p) {
  const Eigen::Vector3d d = p - box.centre;
  const double c = std::cos(box.yaw), s = std::sin(box.yaw);
  const Eigen::Vector3d local(c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z());
  return (local.cwiseAbs() - box.half_size).cwiseMax(0.0).norm();
}

Eigen::Vector3d backProject(const Pose& pose, const CameraIntrinsics& k, int u, int v, float z) {
  return pose * Eigen::Vector3d((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z);
}

bool sameBox(const RoomBox& a, const RoomBox& b) {
  return a.centre == b.centre && a.half_size == b.half_size && a.yaw == b.yaw &&
         a.appearance == b.appearance;
}

// The boxes of `of` that `in` has none exactly alike of.
std::vector<RoomBox> boxesNotIn(const std::vector<RoomBox>& of, const std::vector<RoomBox>& in) {
  std::vector<RoomBox> result;
  for (const RoomBox& box : of)
    if (std::none_of(in.begin(), in.end(), [&](const RoomBox& b) { return sameBox(box, b); }))
      result.push_back(box);
  return result;
}

double meanAbsDifference(const cv::Mat& a, const cv::Mat& b) {
  return cv::norm(a, b, cv::NORM_L1) / static_cast<double>(a.total() * a.channels());
}

}  // namespace

TEST(SceneChanges, TrainingFramesStayByteIdenticalAndTestFramesChange) {
  relocalizer::testing::TempDir plain, changed;
  SyntheticSceneOptions options;
  options.seed = 3;
  options.train_frames = 4;
  options.test_frames = 3;
  options.camera = kTiny;
  options.moving_objects = true;
  ASSERT_TRUE(writeSyntheticScene(plain.str(), options).ok());
  options.test_changes = {2, 2, 2, 2, LampChange::kOn};
  ASSERT_TRUE(writeSyntheticScene(changed.str(), options).ok());
  const auto before = relocalizer::testing::readTree(plain.path()),
             after = relocalizer::testing::readTree(changed.path());
  ASSERT_EQ(before.size(), after.size());
  int test_colour_changed = 0;
  for (const auto& [name, bytes] : before) {
    if (name.rfind("train/", 0) == 0) {
      EXPECT_EQ(bytes, after.at(name)) << name;
    }
    if (name.rfind("test/", 0) == 0 && name.find("color") != std::string::npos)
      test_colour_changed += bytes != after.at(name);
  }
  EXPECT_EQ(test_colour_changed, 3) << "the lamp alone lights every test view differently";
  const std::string json = after.at("scene.json");
  for (const char* part :
       {"\"test_changes\"", "\"people\": 2", "\"moved_furniture\": 2", "\"removed_objects\": 2",
        "\"added_objects\": 2", "\"lamp\": \"on\"", "\"made\""})
    EXPECT_NE(json.find(part), std::string::npos) << part << " not in " << json;
}

TEST(SceneChanges, MovedFurnitureIsTheTestFramesStaticWorld) {
  const SyntheticRoom room(4);
  const SyntheticRoom changed = room.changed({0, 2, 0, 0, LampChange::kNone});
  const std::vector<RoomBox> before = room.boxes(), after = changed.boxes();
  ASSERT_EQ(before.size(), after.size()) << "moving furniture neither adds nor removes boxes";
  // The same boxes, some elsewhere: each moved piece's boxes by one turn about
  // z and shift, at least 0.5 m. The biggest of them is a moved piece's body.
  std::vector<Eigen::Vector3d> motions;  // (turn, shift x, shift y), each once
  int biggest = -1;
  for (size_t i = 0; i < before.size(); ++i) {
    EXPECT_EQ(before[i].half_size, after[i].half_size);
    EXPECT_EQ(before[i].appearance, after[i].appearance);
    if ((before[i].centre - after[i].centre).norm() < 1e-6) continue;
    EXPECT_GE((before[i].centre - after[i].centre).norm(), 0.5) << "box " << i;
    const double turn = std::remainder(after[i].yaw - before[i].yaw, 2 * M_PI);
    const Eigen::Vector3d shift =
        after[i].centre - Eigen::AngleAxisd(turn, Eigen::Vector3d::UnitZ()) * before[i].centre;
    const Eigen::Vector3d motion(turn, shift.x(), shift.y());
    if (std::none_of(motions.begin(), motions.end(),
                     [&](const Eigen::Vector3d& m) { return (m - motion).norm() < 0.01; }))
      motions.push_back(motion);
    if (biggest < 0 || after[i].half_size.prod() > after[biggest].half_size.prod())
      biggest = static_cast<int>(i);
  }
  EXPECT_EQ(motions.size(), 2u) << "two pieces moved";
  EXPECT_EQ(changed.changes().moved_furniture, 2);
  EXPECT_FALSE(room.changes().any());
  // Seen from the middle of the room, the moved piece stands where it now is.
  const RoomBox& piece = after[biggest];
  const Eigen::Vector3d from(room.bounds().center().x(), room.bounds().center().y(), 1.3);
  const Pose pose = lookAt(from, piece.centre);
  const std::optional<double> hit = changed.castRay(from, piece.centre - from);
  ASSERT_TRUE(hit.has_value());
  // On its body, or on a door or drawer front standing proud of it.
  EXPECT_NEAR(boxDistance(piece, from + *hit * (piece.centre - from)), 0.0, 0.03);
  const cv::Mat depth_before = room.exactDepth(pose, kSmall),
                depth_after = changed.exactDepth(pose, kSmall);
  const float centre_depth = depth_after.at<float>(kSmall.height / 2, kSmall.width / 2);
  EXPECT_NEAR(centre_depth, *hit * (pose.linear().transpose() * (piece.centre - from)).z(), 0.02);
  int differ = 0;
  for (int v = 0; v < depth_after.rows; ++v)
    for (int u = 0; u < depth_after.cols; ++u)
      differ += !(std::abs(depth_after.at<float>(v, u) - depth_before.at<float>(v, u)) < 0.05f);
  EXPECT_GT(differ, 0.05 * depth_after.total());
  // A test frame's depth is the changed room's (within the Kinect noise).
  const RgbdFrame frame = changed.render(pose, kSmall, 300);
  const float z = frame.depth.at<float>(kSmall.height / 2, kSmall.width / 2);
  if (std::isfinite(z)) {
    EXPECT_NEAR(z, centre_depth, 0.05);
  }
}

TEST(SceneChanges, PeopleOccludeTestFramesAndMoveButStayOutOfTheGroundTruth) {
  const SyntheticRoom room(4);
  const SyntheticRoom changed = room.changed({3, 0, 0, 0, LampChange::kNone});
  const std::vector<Pose> test = room.trajectories(300, 100).test;
  const auto nearer = [&](const RgbdFrame& frame, const cv::Mat& exact) {
    cv::Mat mask(exact.size(), CV_8UC1, cv::Scalar(0));
    for (int v = 0; v < exact.rows; ++v)
      for (int u = 0; u < exact.cols; ++u)
        mask.at<uint8_t>(v, u) = frame.depth.at<float>(v, u) < exact.at<float>(v, u) - 0.05f;
    return mask;
  };
  int with_people = 0;
  for (int i = 0; i < 100; i += 5) {
    const cv::Mat exact = room.exactDepth(test[i], kTiny);
    ASSERT_EQ(cv::norm(changed.exactDepth(test[i], kTiny), exact, cv::NORM_INF), 0.0)
        << "people are not part of the static ground truth";
    const cv::Mat unchanged = nearer(room.render(test[i], kTiny, 300 + i, exactRender()), exact);
    EXPECT_EQ(cv::countNonZero(unchanged), 0);
    const cv::Mat now = nearer(changed.render(test[i], kTiny, 300 + i, exactRender()), exact);
    if (cv::countNonZero(now) < 0.02 * exact.total()) continue;
    ++with_people;
    // They walk on: the same view a second later shows them elsewhere, or not at all.
    const cv::Mat later = nearer(changed.render(test[i], kTiny, 330 + i, exactRender()), exact);
    EXPECT_GT(cv::countNonZero(now != later), 0.01 * exact.total()) << "frame " << i;
  }
  EXPECT_GE(with_people, 3) << "people should cross the test camera's view now and then";
}

TEST(SceneChanges, ALampSwitchedOnLightsPartOfTheRoomAndChangesNoDepth) {
  const SyntheticRoom room(3);
  const SyntheticRoom on = room.changed({0, 0, 0, 0, LampChange::kOn});
  const SyntheticRoom off = room.changed({0, 0, 0, 0, LampChange::kOff});
  std::vector<double> brighter;
  for (const Pose& pose : viewsAllRound(room)) {
    const RgbdFrame before = room.render(pose, kSmall, 300), lit = on.render(pose, kSmall, 300),
                    dark = off.render(pose, kSmall, 300);
    EXPECT_TRUE(sameImage(before.depth, lit.depth)) << "a light changes no depth";
    EXPECT_TRUE(sameImage(before.depth, dark.depth));
    brighter.push_back(meanAbsDifference(before.colour, lit.colour));
    // A light switched off darkens, never brightens.
    EXPECT_LT(cv::mean(dark.colour)[0] + cv::mean(dark.colour)[1] + cv::mean(dark.colour)[2],
              cv::mean(before.colour)[0] + cv::mean(before.colour)[1] + cv::mean(before.colour)[2]);
  }
  const double most = *std::max_element(brighter.begin(), brighter.end()),
               least = *std::min_element(brighter.begin(), brighter.end());
  EXPECT_GT(most, 8.0) << "the lamp lights the view facing it";
  EXPECT_GT(most, 10 * least) << "and hardly the room's far side: local, not a global gain";
}

// Where colour or depth differs between `room` and `changed`, one of them sees
// one of `boxes` there; and it differs somewhere.
void expectChangesOnlyAt(const SyntheticRoom& room, const SyntheticRoom& changed,
                         const std::vector<RoomBox>& boxes) {
  ASSERT_FALSE(boxes.empty());
  int differ = 0, elsewhere = 0;
  for (const Pose& pose : viewsAllRound(room)) {
    const RgbdFrame a = room.render(pose, kSmall, 300, exactRender()),
                    b = changed.render(pose, kSmall, 300, exactRender());
    for (int v = 0; v < kSmall.height; ++v)
      for (int u = 0; u < kSmall.width; ++u) {
        const float za = a.depth.at<float>(v, u), zb = b.depth.at<float>(v, u);
        if (a.colour.at<cv::Vec3b>(v, u) == b.colour.at<cv::Vec3b>(v, u) && za == zb) continue;
        ++differ;
        double nearest = 1e9;
        for (const RoomBox& box : boxes)
          nearest = std::min({nearest, boxDistance(box, backProject(pose, kSmall, u, v, za)),
                              boxDistance(box, backProject(pose, kSmall, u, v, zb))});
        elsewhere += nearest > 0.01;
      }
  }
  EXPECT_GT(differ, 500);
  EXPECT_EQ(elsewhere, 0) << "of " << differ << " pixels that differ";
}

TEST(SceneChanges, RemovedObjectsChangeTheViewOnlyWhereTheyWere) {
  const SyntheticRoom room(3);
  const SyntheticRoom changed = room.changed({0, 0, 3, 0, LampChange::kNone});
  const std::vector<RoomBox> gone = boxesNotIn(room.boxes(), changed.boxes());
  EXPECT_TRUE(boxesNotIn(changed.boxes(), room.boxes()).empty()) << "the rest stays";
  ASSERT_GE(gone.size(), 3u);
  EXPECT_EQ(changed.changes().removed_objects, 3);
  const Eigen::AlignedBox3d bounds = room.bounds();
  for (const RoomBox& box : gone) {
    // On a wall, or on a desk or cabinet against one.
    const double from_wall =
        std::min({box.centre.x() - bounds.min().x(), bounds.max().x() - box.centre.x(),
                  box.centre.y() - bounds.min().y(), bounds.max().y() - box.centre.y()});
    EXPECT_LT(from_wall, 0.7);
    EXPECT_GT(box.centre.z(), 0.5);
  }
  expectChangesOnlyAt(room, changed, gone);
}

TEST(SceneChanges, AddedDecorationsChangeTheViewOnlyWhereTheyHang) {
  const SyntheticRoom room(3);
  const SyntheticRoom changed = room.changed({0, 0, 0, 3, LampChange::kNone});
  const std::vector<RoomBox> before = room.boxes(), after = changed.boxes();
  ASSERT_GT(after.size(), before.size() + 2);
  for (size_t i = 0; i < before.size(); ++i) EXPECT_TRUE(sameBox(before[i], after[i])) << i;
  const std::vector<RoomBox> added(after.begin() + before.size(), after.end());
  // As many as found a free place on the walls (the room's own fill them).
  EXPECT_GE(changed.changes().added_objects, 1);
  EXPECT_LE(changed.changes().added_objects, 3);
  for (const RoomBox& box : added) {
    EXPECT_GT(box.centre.z(), 0.9);
    EXPECT_TRUE(std::none_of(before.begin(), before.end(), [&](const RoomBox& b) {
      return b.appearance == box.appearance;
    })) << "new decorations have new colours and textures";
  }
  expectChangesOnlyAt(room, changed, added);
}

TEST(SceneChanges, ChangesFollowFromTheSeedAndUnusableOnesAreRejected) {
  const SceneChanges all{3, 2, 2, 2, LampChange::kOn};
  const SyntheticRoom room(6);
  const Pose pose = viewsAllRound(room)[2];
  EXPECT_TRUE(sameImage(room.changed(all).render(pose, kTiny, 301).colour,
                        room.changed(all).render(pose, kTiny, 301).colour));
  EXPECT_FALSE(sameImage(room.changed(all).render(pose, kTiny, 301).colour,
                         room.render(pose, kTiny, 301).colour));
  EXPECT_TRUE(sameImage(room.changed({}).render(pose, kTiny, 301).colour,
                        room.render(pose, kTiny, 301).colour));
  // Changed twice: still at most three people, and they come to no harm.
  const SyntheticRoom twice = room.changed(all).changed(all);
  EXPECT_EQ(twice.changes().people, 3);
  EXPECT_EQ(twice.changes().moved_furniture, 2 * room.changed(all).changes().moved_furniture);
  RenderEffects moving;
  moving.moving_objects = true;
  EXPECT_EQ(twice.render(pose, kTiny, 301, moving).colour.cols, kTiny.width);
  const std::vector<std::pair<SceneChanges, std::string>> bad = {
      {{4, 0, 0, 0, LampChange::kNone}, "--test-people must be from 0 to 3, got 4"},
      {{0, -1, 0, 0, LampChange::kNone}, "--test-moved-furniture must be from 0 to 4, got -1"},
      {{0, 0, 7, 0, LampChange::kNone}, "--test-removed-objects must be from 0 to 6, got 7"},
      {{0, 0, 0, 9, LampChange::kNone}, "--test-added-objects must be from 0 to 6, got 9"}};
  for (const auto& [changes, message] : bad) {
    EXPECT_EQ(changes.validationError(), message);
    EXPECT_THROW(room.changed(changes), std::invalid_argument);
    SyntheticSceneOptions options;
    options.test_changes = changes;
    EXPECT_NE(options.validationError().find(message), std::string::npos);
  }
  relocalizer::testing::TempDir dir;
  const fs::path err = dir.path() / "stderr.txt";
  const std::string out = "--output '" + (dir.path() / "scene").string() + "'";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {out + " --test-people 4", "--test-people: expected a whole number from 0 to 3, got '4'"},
      {out + " --test-lamp dim", "--test-lamp: expected one of none, off, on, got 'dim'"},
      {out + " --rooms 2 --test-people 1", "--test-*: the walk is rendered without changes"}};
  for (const auto& [arguments, reason] : cases) {
    EXPECT_EQ(relocalizer::testing::runTool("synthesize", arguments, err), 2) << arguments;
    const std::string message = relocalizer::testing::readBytes(err);
    EXPECT_NE(message.find(reason), std::string::npos) << arguments << ": " << message;
  }
  EXPECT_FALSE(fs::exists(dir.path() / "scene"));
}
