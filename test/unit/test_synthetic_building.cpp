#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <tuple>

#include "relocalizer/core/frame.h"
#include "relocalizer/data/dataset.h"
#include "relocalizer/sim/building_walk.h"
#include "relocalizer/sim/synthetic_building.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;
namespace fs = std::filesystem;

namespace {

const CameraIntrinsics kSmall = CameraIntrinsics::kinectDefault().scaledTo(320, 240);
const CameraIntrinsics kTiny = CameraIntrinsics::kinectDefault().scaledTo(80, 60);

std::vector<BuildingRoom> rooms(uint64_t seed, int count) {
  Expected<std::vector<BuildingRoom>> result = buildingRooms(seed, count);
  EXPECT_TRUE(result.ok()) << result.error();
  return result.ok() ? std::move(result).value() : std::vector<BuildingRoom>{};
}

// Share of pixels whose colour differs by more than 40 grey levels in some channel.
double differingShare(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  int differing = 0;
  for (int v = 0; v < diff.rows; ++v)
    for (int u = 0; u < diff.cols; ++u) {
      const cv::Vec3b d = diff.at<cv::Vec3b>(v, u);
      differing += std::max({d[0], d[1], d[2]}) > 40 ? 1 : 0;
    }
  return static_cast<double>(differing) / diff.total();
}

// Rooms of 2 training frames at 80 x 60: quick to write.
SyntheticBuildingOptions tinyBuilding(uint64_t seed, int rooms, int test_frames) {
  SyntheticBuildingOptions options;
  options.scene.seed = seed;
  options.scene.train_frames = 2;
  options.scene.test_frames = test_frames;
  options.scene.camera = kTiny;
  options.rooms = rooms;
  return options;
}

RenderEffects noiseless() {
  RenderEffects effects;
  effects.depth_noise = false;
  return effects;
}

// A box's size and looks, whatever its place.
using Looks = std::tuple<double, double, double, uint64_t>;
std::vector<Looks> looksOf(const SyntheticRoom& room) {
  std::vector<Looks> looks;
  for (const RoomBox& box : room.boxes())
    looks.emplace_back(box.half_size.x(), box.half_size.y(), box.half_size.z(), box.appearance);
  std::sort(looks.begin(), looks.end());
  return looks;
}

// The motion taking a box's own frame in one room to the same box's in another.
Eigen::Isometry3d boxMotion(const RoomBox& from, const RoomBox& to) {
  const auto frame = [](const RoomBox& box) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translate(box.centre);
    pose.rotate(Eigen::AngleAxisd(box.yaw, Eigen::Vector3d::UnitZ()));
    return pose;
  };
  return frame(to) * frame(from).inverse();
}

// A camera 1.5 m height-level with `target`, `distance` from it towards the
// room's centre, looking at it.
Pose lookingAt(const Eigen::Vector3d& target, const Eigen::Vector3d& room_centre, double distance) {
  Eigen::Vector3d away(room_centre.x() - target.x(), room_centre.y() - target.y(), 0);
  away.normalize();
  const Eigen::Vector3d eye = target + distance * away;
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Pose pose = Pose::Identity();
  pose.linear().col(0) = x;
  pose.linear().col(1) = y;
  pose.linear().col(2) = z;
  pose.translation() = eye;
  return pose;
}

// Summed volume that pairs of boxes' bounds share: pieces moved onto one
// another would add to it.
double sharedVolume(const SyntheticRoom& room) {
  std::vector<Eigen::AlignedBox3d> bounds;
  for (const RoomBox& box : room.boxes()) {
    const double c = std::abs(std::cos(box.yaw)), s = std::abs(std::sin(box.yaw));
    const Eigen::Vector3d extent(c * box.half_size.x() + s * box.half_size.y(),
                                 s * box.half_size.x() + c * box.half_size.y(), box.half_size.z());
    bounds.emplace_back(box.centre - extent, box.centre + extent);
  }
  double volume = 0;
  for (size_t i = 0; i < bounds.size(); ++i)
    for (size_t j = i + 1; j < bounds.size(); ++j)
      if (bounds[i].intersects(bounds[j])) volume += bounds[i].intersection(bounds[j]).volume();
  return volume;
}

}  // namespace

TEST(SyntheticBuilding, NamesSeedsAndTheLookAlikePair) {
  const std::vector<BuildingRoom> two = rooms(40, 2);
  ASSERT_EQ(two.size(), 2u);
  for (const BuildingRoom& room : two) {
    EXPECT_EQ(room.looks_like, -1) << "two rooms are two rooms that differ";
    EXPECT_EQ(room.recipe.appearance_seed, room.recipe.layout_seed);
  }
  const std::vector<BuildingRoom> five = rooms(40, 5);
  ASSERT_EQ(five.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(five[i].name, "room-" + std::to_string(i));
    EXPECT_EQ(five[i].recipe.layout_seed, 40u + i);
  }
  EXPECT_EQ(five[0].looks_like, 4);
  EXPECT_EQ(five[4].looks_like, 0);
  EXPECT_EQ(five[4].recipe.appearance_seed, 40u);
  for (int i = 1; i < 4; ++i) EXPECT_EQ(five[i].looks_like, -1);
  // Side by side along x, without overlapping; each room's bounds are its own, placed.
  for (int i = 0; i < 5; ++i) {
    if (i > 0) {
      EXPECT_NEAR(five[i].bounds_in_building.min().x(),
                  five[i - 1].bounds_in_building.max().x() + kBuildingWallThickness, 1e-9);
    }
    const Eigen::AlignedBox3d own = SyntheticRoom(five[i].recipe).bounds();
    Eigen::AlignedBox3d placed;
    for (int c = 0; c < 8; ++c)
      placed.extend(five[i].room_to_building *
                    own.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)));
    EXPECT_TRUE(placed.min().isApprox(five[i].bounds_in_building.min(), 1e-12)) << i;
    EXPECT_TRUE(placed.max().isApprox(five[i].bounds_in_building.max(), 1e-12)) << i;
  }
}

TEST(SyntheticBuilding, RefusesRoomCountsOutsideItsRange) {
  for (const int count : {0, 1, -1, kMaxBuildingRooms + 1, INT_MAX, INT_MIN}) {
    const auto result = buildingRooms(1, count);
    ASSERT_FALSE(result.ok()) << count;
    EXPECT_NE(result.error().find("rooms"), std::string::npos) << result.error();
    EXPECT_NE(result.error().find(std::to_string(count)), std::string::npos) << result.error();
  }
  SyntheticBuildingOptions options;
  options.rooms = 1;
  EXPECT_NE(options.validationError().find("rooms"), std::string::npos);
  relocalizer::testing::TempDir dir;
  EXPECT_FALSE(writeSyntheticBuilding((dir.path() / "b").string(), options).ok());
  EXPECT_FALSE(fs::exists(dir.path() / "b"));
}

TEST(SyntheticBuilding, RoomsThatAreNotThePairDiffer) {
  const std::vector<BuildingRoom> building = rooms(3, 4);
  std::vector<SyntheticRoom> built;
  for (const BuildingRoom& room : building) built.emplace_back(room.recipe);
  const std::vector<Pose> poses = built[0].trajectories(8, 0).train;
  for (size_t a = 0; a < built.size(); ++a)
    for (size_t b = a + 1; b < built.size(); ++b) {
      if (building[a].looks_like == static_cast<int>(b)) continue;
      EXPECT_NE(looksOf(built[a]), looksOf(built[b])) << a << " " << b;
      double share = 0;
      for (size_t i = 0; i < poses.size(); i += 2)
        share += differingShare(built[a].render(poses[i], kSmall, 0, noiseless()).colour,
                                built[b].render(poses[i], kSmall, 0, noiseless()).colour);
      EXPECT_GT(share / 4, 0.5) << "rooms " << a << " and " << b << " look too much alike";
    }
}

TEST(SyntheticBuilding, TheLookAlikePairSharesEveryPieceButNotItsPlace) {
  for (const uint64_t seed : {1, 2, 9, 77}) {
    const std::vector<BuildingRoom> building = rooms(seed, 3);
    const SyntheticRoom original(building[0].recipe), look_alike(building[2].recipe);
    EXPECT_TRUE(original.bounds().isApprox(look_alike.bounds()));
    EXPECT_EQ(looksOf(original), looksOf(look_alike)) << "seed " << seed;
    const std::vector<RoomBox> a = original.boxes(), b = look_alike.boxes();
    ASSERT_EQ(a.size(), b.size());
    int moved = 0;
    for (size_t i = 0; i < a.size(); ++i) moved += (a[i].centre - b[i].centre).norm() > 0.5;
    EXPECT_GT(moved, static_cast<int>(a.size()) / 4) << "seed " << seed;
    // Seen from the same poses round the room, they differ.
    const std::vector<Pose> poses = original.trajectories(320, 0).train;
    double share = 0;
    for (size_t i = 0; i < poses.size(); i += 40)
      share += differingShare(original.render(poses[i], kSmall, 0, noiseless()).colour,
                              look_alike.render(poses[i], kSmall, 0, noiseless()).colour);
    EXPECT_GT(share / 8, 0.3) << "seed " << seed;
    // And their own camera paths lie elsewhere.
    EXPECT_GT(
        (look_alike.trajectories(320, 0).train[5].translation() - poses[5].translation()).norm(),
        0.05);
  }
}

TEST(SyntheticBuilding, TheLookAlikesPiecesDoNotRunIntoEachOther) {
  for (uint64_t seed = 1; seed <= 30; ++seed) {
    const std::vector<BuildingRoom> building = rooms(seed, 3);
    const double original = sharedVolume(SyntheticRoom(building[0].recipe));
    const double look_alike = sharedVolume(SyntheticRoom(building[2].recipe));
    // Pieces of one room touch their walls and each other a little; two
    // pieces run into each other share tenths of a cubic metre.
    EXPECT_LT(look_alike, original + 0.01) << "seed " << seed;
  }
}

TEST(SyntheticBuilding, ACloseUpOfAMovedPieceLooksTheSameInBothRooms) {
  const std::vector<BuildingRoom> building = rooms(5, 3);
  const SyntheticRoom original(building[0].recipe), look_alike(building[2].recipe),
      other(building[1].recipe);
  const std::vector<RoomBox> a = original.boxes(), b = look_alike.boxes();
  // The largest box standing on the floor that moved: a piece of furniture.
  int chosen = -1;
  for (size_t i = 0; i < a.size(); ++i) {
    const bool on_floor = a[i].centre.z() - a[i].half_size.z() < 0.1 && a[i].half_size.z() > 0.35;
    const bool moved = (a[i].centre - b[i].centre).norm() > 0.5;
    if (on_floor && moved && (chosen < 0 || a[i].half_size.prod() > a[chosen].half_size.prod()))
      chosen = static_cast<int>(i);
  }
  ASSERT_GE(chosen, 0);
  const Eigen::Vector3d target(a[chosen].centre.x(), a[chosen].centre.y(), 1.0);
  const Pose here = lookingAt(target, original.bounds().center(), 0.9);
  const Pose there = boxMotion(a[chosen], b[chosen]) * here;
  const cv::Mat seen = original.render(here, kSmall, 0, noiseless()).colour;
  // Only the lights fall differently on it.
  EXPECT_LT(differingShare(seen, look_alike.render(there, kSmall, 0, noiseless()).colour), 0.1);
  EXPECT_GT(differingShare(seen, other.render(here, kSmall, 0, noiseless()).colour), 0.3);
}

TEST(SyntheticBuilding, WritesEveryRoomAsADatasetAndTheSameSeedGivesTheSameBytes) {
  relocalizer::testing::TempDir a, b, single;
  SyntheticBuildingOptions options = tinyBuilding(11, 4, 1);
  options.scene.moving_objects = true;
  ASSERT_TRUE(writeSyntheticBuilding(a.str(), options).ok());
  options.rooms = 3;
  ASSERT_TRUE(writeSyntheticBuilding(a.str(), options).ok());
  EXPECT_FALSE(fs::exists(a.path() / "room-3")) << "a room building.json no longer names";
  ASSERT_TRUE(writeSyntheticBuilding(b.str(), options).ok());
  const auto first = relocalizer::testing::readTree(a.path()),
             second = relocalizer::testing::readTree(b.path());
  // building.json, and per room 3 frames x 3 files, 2 x 2 camera files, scene.json, contact sheet.
  EXPECT_EQ(first.size(), 1u + 3 * (3 * 3 + 2 * 2 + 2));
  EXPECT_TRUE(first == second);

  // Room 0 is the single room of the building's seed.
  ASSERT_TRUE(writeSyntheticScene(single.str(), options.scene).ok());
  for (const auto& [name, bytes] : relocalizer::testing::readTree(single.path()))
    EXPECT_EQ(first.at("room-0/" + name), bytes) << name;

  const nlohmann::json json = nlohmann::json::parse(first.at("building.json"));
  ASSERT_EQ(json["rooms"].size(), 3u);
  EXPECT_EQ(json["look_alike_pair"], nlohmann::json({"room-0", "room-2"}));
  const std::vector<BuildingRoom> expected = rooms(11, 3);
  for (int i = 0; i < 3; ++i) {
    const nlohmann::json& room = json["rooms"][i];
    EXPECT_EQ(room["name"], expected[i].name);
    EXPECT_EQ(room["seed"].get<uint64_t>(), expected[i].recipe.layout_seed);
    EXPECT_EQ(room["appearance_seed"].get<uint64_t>(), expected[i].recipe.appearance_seed);
    EXPECT_NEAR(room["room_to_building"][0][3].get<double>(),
                expected[i].room_to_building.translation().x(), 1e-12);
    const fs::path folder = a.path() / room["folder"].get<std::string>();
    const nlohmann::json scene =
        nlohmann::json::parse(relocalizer::testing::readBytes(folder / "scene.json"));
    EXPECT_EQ(scene["seed"].get<uint64_t>(), expected[i].recipe.layout_seed);
    EXPECT_EQ(scene.contains("appearance_seed"), i == 2);
    const Expected<std::unique_ptr<Dataset>> dataset = openDataset((folder / "test").string());
    ASSERT_TRUE(dataset.ok()) << dataset.error();
    const Expected<RgbdFrame> frame = (*dataset)->load(0);
    ASSERT_TRUE(frame.ok()) << frame.error();
    const SyntheticRoom built(expected[i].recipe);
    const Pose pose = built.trajectories(2, 1).test[0];
    RenderEffects effects;
    effects.moving_objects = true;
    const cv::Mat colour = built.render(pose, kTiny, 2, effects).colour;
    EXPECT_EQ(cv::norm(frame->colour, colour, cv::NORM_INF), 0) << room["name"];
  }
}

TEST(SyntheticBuildingTool, RefusesBadRoomCountsNamingTheOption) {
  relocalizer::testing::TempDir dir;
  const fs::path err = dir.path() / "stderr.txt";
  const std::string out = "--output '" + (dir.path() / "b").string() + "'";
  for (const std::string count : {"0", "1", "-2", "101", "99999999999999999999", "three"}) {
    EXPECT_EQ(relocalizer::testing::runTool("synthesize", out + " --rooms " + count, err), 2)
        << count;
    const std::string message = relocalizer::testing::readBytes(err);
    EXPECT_NE(message.find("--rooms"), std::string::npos) << message;
    EXPECT_EQ(std::count(message.begin(), message.end(), '\n'), 1) << message;
  }
  EXPECT_FALSE(fs::exists(dir.path() / "b"));
}

TEST(SyntheticBuildingTool, WritesABuilding) {
  relocalizer::testing::TempDir dir;
  const fs::path out = dir.path() / "b";
  ASSERT_EQ(relocalizer::testing::runTool(
                "synthesize",
                "--output '" + out.string() +
                    "' --rooms 3 --seed 4 --train-frames 2 --test-frames 1 --width 80 "
                    "--height 60 --illumination-change --no-walk",
                dir.path() / "stderr.txt"),
            0)
      << relocalizer::testing::readBytes(dir.path() / "stderr.txt");
  EXPECT_TRUE(fs::exists(out / "building.json"));
  const nlohmann::json building =
      nlohmann::json::parse(relocalizer::testing::readBytes(out / "building.json"));
  EXPECT_EQ(building["format_version"].get<int>(), 2);
  EXPECT_EQ(building["corridor"]["max"][1].get<double>(), kCorridorNearY);
  for (const auto& room : building["rooms"])
    EXPECT_EQ(room["door"]["inward"][1].get<double>(), 1.0);
  for (const char* room : {"room-0", "room-1", "room-2"}) {
    EXPECT_TRUE(fs::exists(out / room / "test" / "frame-000000.color.png")) << room;
    const nlohmann::json scene =
        nlohmann::json::parse(relocalizer::testing::readBytes(out / room / "scene.json"));
    EXPECT_TRUE(scene["effects"]["illumination_change"].get<bool>()) << room;
    EXPECT_EQ(scene["camera"]["width"].get<int>(), 80) << room;
  }
}

// ---------------------------------------------------------------- doors and the walk

namespace {

// The room's extent along a horizontal axis-aligned direction.
double extentAlong(const SyntheticRoom& room, const Eigen::Vector3d& direction) {
  return std::abs(room.bounds().sizes().dot(direction));
}

BuildingWalkOptions quickWalk() {
  BuildingWalkOptions options;
  options.loop_frames = 2;  // the shortest closed loop, kSyntheticLoopFrames
  return options;
}

bool insideShrunk(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& p, double margin) {
  const Eigen::Vector3d m = Eigen::Vector3d::Constant(margin);
  return (p.array() > (box.min() + m).array()).all() && (p.array() < (box.max() - m).array()).all();
}

}  // namespace

TEST(SyntheticBuilding, EachRoomsDoorIsWhereTheRoomSaysItIs) {
  std::map<std::pair<long, long>, int> walls;  // inward normals seen
  for (uint64_t seed = 1; seed <= 24; ++seed) {
    const SyntheticRoom room(seed);
    const RoomDoor door = room.door();
    const Eigen::AlignedBox3d bounds = room.bounds();
    ASSERT_NEAR(door.inward.norm(), 1.0, 1e-12) << seed;
    ASSERT_NEAR(door.inward.z(), 0.0, 1e-12) << seed;
    ++walls[{std::lround(door.inward.x()), std::lround(door.inward.y())}];
    // On the wall the normal leaves: the wall's plane is the room's face there.
    const Eigen::Vector3d face =
        door.inward.x() + door.inward.y() > 0 ? bounds.min() : bounds.max();
    EXPECT_NEAR(door.inward.dot(door.centre), door.inward.dot(face), 1e-6) << seed;
    EXPECT_NEAR(door.centre.z(), door.height / 2, 1e-6) << seed;
    EXPECT_GE(door.width, 0.82 - 1e-6);
    EXPECT_LE(door.width, 0.92 + 1e-6);
    EXPECT_GE(door.height, 2.0 - 1e-6);
    EXPECT_LE(door.height, 2.1 + 1e-6);
    // 10 cm in front of it: looking out, the door's leaf (12-20 mm thick with
    // its panels); looking in, across the room to the opposite wall, or what
    // stands against it (furniture is at most ~0.65 m deep).
    const Eigen::Vector3d inside = door.centre + 0.1 * door.inward;
    const std::optional<double> out = room.castRay(inside, -door.inward);
    ASSERT_TRUE(out.has_value()) << seed;
    EXPECT_GE(*out, 0.1 - 0.02 - 1e-4) << seed;
    EXPECT_LE(*out, 0.1 - 0.012 + 1e-4) << seed;
    const std::optional<double> across = room.castRay(inside, door.inward);
    ASSERT_TRUE(across.has_value()) << seed;
    const double opposite = extentAlong(room, door.inward) - 0.1;
    EXPECT_LE(*across, opposite + 1e-4) << seed;
    EXPECT_GE(*across, opposite - 0.7) << seed;
    // And a look-alike keeps its original's door.
    const RoomDoor same = SyntheticRoom(RoomRecipe{seed, seed + 1000}).door();
    EXPECT_EQ(same.centre, door.centre);
    EXPECT_EQ(same.inward, door.inward);
  }
  EXPECT_EQ(walls.size(), 4u) << "24 rooms should have doors on every wall";
}

TEST(SyntheticBuilding, PlacedDoorsOpenOntoTheCorridorAndRoomsDoNotOverlap) {
  int turned = 0;
  for (const uint64_t seed : {1, 5, 11, 40}) {
    const std::vector<BuildingRoom> building = rooms(seed, 6);
    const Eigen::AlignedBox3d corridor = buildingCorridor(building);
    for (size_t i = 0; i < building.size(); ++i) {
      const BuildingRoom& room = building[i];
      const SyntheticRoom built(room.recipe);
      // A quarter turn about z with exact entries.
      const Eigen::Matrix3d turn = room.room_to_building.linear();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) EXPECT_EQ(turn(r, c), std::round(turn(r, c))) << seed << i;
      EXPECT_EQ(turn(2, 2), 1.0);
      turned += turn.isIdentity() ? 0 : 1;
      EXPECT_TRUE(room.door.inward.isApprox(Eigen::Vector3d::UnitY(), 1e-12)) << seed << " " << i;
      EXPECT_NEAR(room.door.centre.y(), 0.0, 1e-9) << "sill off y = 0: " << seed << " " << i;
      EXPECT_NEAR(room.door.centre.z() - room.door.height / 2, 0.0, 1e-6);
      EXPECT_TRUE((room.room_to_building * built.door().centre).isApprox(room.door.centre));
      EXPECT_NEAR(room.bounds_in_building.min().y(), 0.0, 1e-9);
      EXPECT_GT(room.door.centre.x(), room.bounds_in_building.min().x());
      EXPECT_LT(room.door.centre.x(), room.bounds_in_building.max().x());
      EXPECT_FALSE(corridor.intersection(room.bounds_in_building).volume() > 0);
      for (size_t j = i + 1; j < building.size(); ++j)
        EXPECT_FALSE(building[j].bounds_in_building.intersects(room.bounds_in_building))
            << seed << ": rooms " << i << " and " << j;
    }
  }
  EXPECT_GT(turned, 4) << "some of these doors are not on wall 0: the turns must be exercised";
}

TEST(SyntheticBuildingWalk, GoesRoundEveryRoomInSmallStepsThroughItsDoor) {
  const std::vector<BuildingRoom> building = rooms(11, 3);
  const Eigen::AlignedBox3d corridor = buildingCorridor(building);
  const BuildingWalkOptions options = quickWalk();
  const std::vector<WalkTick> walk = buildingWalk(building, options);
  ASSERT_GT(walk.size(), 3u * kSyntheticLoopFrames);
  std::vector<int> rendered(building.size(), 0), loop_poses_seen(building.size(), 0);
  std::vector<std::vector<Pose>> loops;
  std::vector<SyntheticRoom> built;
  std::vector<Eigen::AlignedBox3d> own_bounds;
  for (const BuildingRoom& room : building) {
    built.emplace_back(room.recipe);
    loops.push_back(built.back().trajectories(kSyntheticLoopFrames, 0).train);
    own_bounds.push_back(built.back().bounds());
  }
  for (size_t t = 0; t < walk.size(); ++t) {
    const WalkTick& tick = walk[t];
    const Pose& pose = tick.building_pose;
    ASSERT_GE(tick.room, 0);
    ASSERT_LT(tick.room, 3);
    if (t > 0) {
      EXPECT_LE(translationError(pose, walk[t - 1].building_pose), 0.03) << t;
      EXPECT_LE(rotationErrorDegrees(pose, walk[t - 1].building_pose), 3.0) << t;
      EXPECT_TRUE(tick.room == walk[t - 1].room || tick.room == walk[t - 1].room + 1) << t;
    }
    EXPECT_LT(pose.linear().col(1).z(), -0.8) << "the camera must stay upright: tick " << t;
    const BuildingRoom& room = building[tick.room];
    const Eigen::Vector3d p = pose.translation();
    const Eigen::Vector3d in_room = room.room_to_building.inverse() * p;
    const Eigen::AlignedBox3d& own = own_bounds[tick.room];
    // Rendered exactly when well inside its own room; elsewhere in the corridor or a doorway.
    EXPECT_EQ(tick.rendered, insideShrunk(own, in_room, options.render_margin)) << t;
    if (tick.rendered) {
      ++rendered[tick.room];
      // Never into the furniture: a camera crossing a surface would pass
      // within half a step (~1 cm) of it; the door's leaf is the nearest.
      EXPECT_GT(built[tick.room].surfaceDistance(in_room), 0.2) << t;
    }
    const bool in_a_room = own.contains(in_room);
    const bool in_corridor = corridor.contains(p);
    const bool in_doorway = std::abs(p.x() - room.door.centre.x()) < room.door.width / 2 &&
                            p.y() >= corridor.max().y() - 1e-9 && p.y() <= 1e-9;
    EXPECT_TRUE(in_a_room || in_corridor || in_doorway) << t << ": " << p.transpose();
    for (const Pose& loop_pose : loops[tick.room])
      if ((room.room_to_building * loop_pose).isApprox(pose, 1e-12)) ++loop_poses_seen[tick.room];
  }
  EXPECT_FALSE(walk.front().rendered);
  EXPECT_FALSE(walk.back().rendered);
  EXPECT_TRUE(corridor.contains(walk.front().building_pose.translation()));
  EXPECT_TRUE(corridor.contains(walk.back().building_pose.translation()));
  for (size_t r = 0; r < building.size(); ++r) {
    // Once round: every loop pose, the first one again at the end.
    EXPECT_EQ(loop_poses_seen[r], kSyntheticLoopFrames + 1) << r;
    EXPECT_GT(rendered[r], kSyntheticLoopFrames) << r;
  }
  // The same rooms give the same walk; unusable options none.
  const std::vector<WalkTick> again = buildingWalk(building, options);
  ASSERT_EQ(again.size(), walk.size());
  EXPECT_TRUE(again.back().building_pose.isApprox(walk.back().building_pose, 0));
  BuildingWalkOptions bad = options;
  bad.max_step_metres = 0;
  EXPECT_TRUE(buildingWalk(building, bad).empty());
  EXPECT_FALSE(bad.validationError().empty());
}

TEST(SyntheticBuildingWalk, WritesOneDatasetOfTheWalkAndEveryRoomsTestFrames) {
  relocalizer::testing::TempDir dir;
  SyntheticBuildingOptions options = tinyBuilding(7, 2, 2);
  options.scene.illumination_change = true;
  ASSERT_TRUE(writeSyntheticBuilding(dir.str(), options).ok());
  const std::vector<BuildingRoom> building = rooms(7, 2);
  const BuildingWalkOptions walk_options = quickWalk();
  ASSERT_TRUE(writeBuildingWalk(dir.str(), building, options.scene, walk_options).ok());
  const std::vector<WalkTick> walk = buildingWalk(building, walk_options);
  const fs::path folder = dir.path() / kWalkFolder;

  const nlohmann::json json =
      nlohmann::json::parse(relocalizer::testing::readBytes(folder / "walk.json"));
  EXPECT_EQ(json["ticks"].get<size_t>(), walk.size());
  std::vector<int> rendered;
  for (size_t t = 0; t < walk.size(); ++t)
    if (walk[t].rendered) rendered.push_back(static_cast<int>(t));
  EXPECT_EQ(json["rendered"].get<size_t>(), rendered.size());
  for (int r = 0; r < 2; ++r) {
    const nlohmann::json& room = json["rooms"][r];
    int last = -1;
    for (size_t t = 0; t < walk.size(); ++t)
      if (walk[t].room == r && walk[t].rendered) last = static_cast<int>(t);
    EXPECT_EQ(room["exit_tick"].get<int>(), last) << r;
    EXPECT_EQ(room["test_ids"], nlohmann::json({500000 + 1000 * r, 500001 + 1000 * r}));
  }

  // One dataset: the rendered ticks, then the test frames of both rooms.
  const Expected<std::unique_ptr<Dataset>> dataset = openDataset(folder.string());
  ASSERT_TRUE(dataset.ok()) << dataset.error();
  ASSERT_EQ((*dataset)->size(), rendered.size() + 4);
  for (const size_t i : {size_t{0}, rendered.size() / 2, rendered.size() - 1}) {
    const int t = rendered[i];
    ASSERT_EQ((*dataset)->id(i), t);
    const WalkTick& tick = walk[t];
    ASSERT_TRUE((*dataset)->groundTruth(i).has_value());
    EXPECT_LT(translationError(*(*dataset)->groundTruth(i), tick.building_pose), 1e-6);
    const Expected<RgbdFrame> frame = (*dataset)->load(i);
    ASSERT_TRUE(frame.ok()) << frame.error();
    RenderEffects effects;
    effects.illumination_change = true;
    const Pose in_room = building[tick.room].room_to_building.inverse() * tick.building_pose;
    const cv::Mat colour =
        SyntheticRoom(building[tick.room].recipe).render(in_room, kTiny, t, effects).colour;
    EXPECT_EQ(cv::norm(frame->colour, colour, cv::NORM_INF), 0) << "tick " << t;
  }
  for (int r = 0; r < 2; ++r)
    for (int i = 0; i < 2; ++i) {
      const size_t index = rendered.size() + 2 * r + i;
      ASSERT_EQ((*dataset)->id(index), 500000 + 1000 * r + i);
      const std::string stem = "frame-" + std::to_string(500000 + 1000 * r + i);
      const fs::path own =
          dir.path() / building[r].name / "test" / ("frame-00000" + std::to_string(i));
      EXPECT_EQ(relocalizer::testing::readBytes(folder / (stem + ".color.png")),
                relocalizer::testing::readBytes(own.string() + ".color.png"));
      EXPECT_EQ(relocalizer::testing::readBytes(folder / (stem + ".depth.png")),
                relocalizer::testing::readBytes(own.string() + ".depth.png"));
      const Pose truth = building[r].room_to_building *
                         SyntheticRoom(building[r].recipe).trajectories(2, 2).test[i];
      EXPECT_LT(translationError(*(*dataset)->groundTruth(index), truth), 1e-6);
      EXPECT_LT(rotationErrorDegrees(*(*dataset)->groundTruth(index), truth), 1e-5);
    }

  // A pose at every tick, stamped tick / rate.
  std::ifstream poses(folder / "walk_poses.txt");
  std::string line;
  size_t lines = 0;
  while (std::getline(poses, line)) {
    if (line.empty() || line[0] == '#') continue;
    double stamp, x, y, z;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf %lf %lf %lf", &stamp, &x, &y, &z), 4) << line;
    EXPECT_NEAR(stamp, lines / walk_options.rate, 1e-6);
    EXPECT_NEAR(x, walk[lines].building_pose.translation().x(), 1e-8);
    ++lines;
  }
  EXPECT_EQ(lines, walk.size());

  // The building written again drops the walk it no longer matches.
  ASSERT_TRUE(writeSyntheticBuilding(dir.str(), options).ok());
  EXPECT_FALSE(fs::exists(folder));
}

TEST(SyntheticBuildingTool, RoomZeroIsTheSingleRoomOfItsSeedAndNoWalkWritesNone) {
  relocalizer::testing::TempDir dir;
  const std::string common = " --seed 9 --train-frames 2 --test-frames 1 --width 80 --height 60";
  const fs::path err = dir.path() / "stderr.txt";
  ASSERT_EQ(
      relocalizer::testing::runTool(
          "synthesize", "--output '" + (dir.path() / "b").string() + "' --rooms 2" + common, err),
      0)
      << relocalizer::testing::readBytes(err);
  ASSERT_EQ(relocalizer::testing::runTool(
                "synthesize", "--output '" + (dir.path() / "one").string() + "'" + common, err),
            0)
      << relocalizer::testing::readBytes(err);
  const auto single = relocalizer::testing::readTree(dir.path() / "one");
  EXPECT_EQ(relocalizer::testing::readTree(dir.path() / "b" / "room-0"), single);
  const fs::path walk = dir.path() / "b" / "walk";
  ASSERT_TRUE(fs::exists(walk / "walk_poses.txt"));
  const nlohmann::json json =
      nlohmann::json::parse(relocalizer::testing::readBytes(walk / "walk.json"));
  EXPECT_EQ(json["loop_frames"].get<int>(), kSyntheticLoopFrames) << "2 training frames are an arc";
  EXPECT_TRUE(fs::exists(walk / "frame-501000.color.png")) << "room-1's test frame";
  const int exit = json["rooms"][0]["exit_tick"].get<int>();
  EXPECT_TRUE(fs::exists(walk / ("frame-" + std::string(6 - std::to_string(exit).size(), '0') +
                                 std::to_string(exit) + ".depth.png")));

  ASSERT_EQ(relocalizer::testing::runTool(
                "synthesize",
                "--output '" + (dir.path() / "b").string() + "' --rooms 2 --no-walk" + common, err),
            0)
      << relocalizer::testing::readBytes(err);
  EXPECT_FALSE(fs::exists(dir.path() / "b" / "walk"));
  EXPECT_EQ(relocalizer::testing::readTree(dir.path() / "b" / "room-0"), single);
  // More test frames than a walk has ids for: refused before anything is written.
  EXPECT_EQ(relocalizer::testing::runTool(
                "synthesize",
                "--output '" + (dir.path() / "c").string() + "' --rooms 2 --test-frames 1001", err),
            2);
  EXPECT_NE(relocalizer::testing::readBytes(err).find("--no-walk"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir.path() / "c"));
}
