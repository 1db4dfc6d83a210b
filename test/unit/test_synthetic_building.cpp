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

std::string fileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::map<std::string, std::string> filesBelow(const fs::path& root) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(root))
    if (entry.is_regular_file())
      files[fs::relative(entry.path(), root).string()] = fileBytes(entry.path());
  return files;
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

int runTool(const std::string& arguments, const fs::path& stderr_file) {
  const std::string command = std::string(RELOCALIZER_TOOL_DIR) + "/synthesize " + arguments +
                              " > /dev/null 2> '" + stderr_file.string() + "'";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
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
  // Side by side along x, without overlapping.
  for (int i = 1; i < 5; ++i) {
    EXPECT_NEAR(five[i].bounds_in_building.min().x(),
                five[i - 1].bounds_in_building.max().x() + kBuildingWallThickness, 1e-9);
    const Eigen::AlignedBox3d own = SyntheticRoom(five[i].recipe).bounds();
    EXPECT_TRUE((five[i].room_to_building * own.max()).isApprox(five[i].bounds_in_building.max()));
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
  SyntheticBuildingOptions options;
  options.scene.seed = 11;
  options.scene.train_frames = 2;
  options.scene.test_frames = 1;
  options.scene.camera = kTiny;
  options.scene.moving_objects = true;
  options.rooms = 4;
  ASSERT_TRUE(writeSyntheticBuilding(a.str(), options).ok());
  options.rooms = 3;
  ASSERT_TRUE(writeSyntheticBuilding(a.str(), options).ok());
  EXPECT_FALSE(fs::exists(a.path() / "room-3")) << "a room building.json no longer names";
  ASSERT_TRUE(writeSyntheticBuilding(b.str(), options).ok());
  const auto first = filesBelow(a.path()), second = filesBelow(b.path());
  // building.json, and per room 3 frames x 3 files, 2 x 2 camera files, scene.json, contact sheet.
  EXPECT_EQ(first.size(), 1u + 3 * (3 * 3 + 2 * 2 + 2));
  EXPECT_TRUE(first == second);

  // Room 0 is the single room of the building's seed.
  ASSERT_TRUE(writeSyntheticScene(single.str(), options.scene).ok());
  for (const auto& [name, bytes] : filesBelow(single.path()))
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
    const nlohmann::json scene = nlohmann::json::parse(fileBytes(folder / "scene.json"));
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
    EXPECT_EQ(runTool(out + " --rooms " + count, err), 2) << count;
    const std::string message = fileBytes(err);
    EXPECT_NE(message.find("--rooms"), std::string::npos) << message;
    EXPECT_EQ(std::count(message.begin(), message.end(), '\n'), 1) << message;
  }
  EXPECT_FALSE(fs::exists(dir.path() / "b"));
}

TEST(SyntheticBuildingTool, WritesABuilding) {
  relocalizer::testing::TempDir dir;
  const fs::path out = dir.path() / "b";
  ASSERT_EQ(runTool("--output '" + out.string() +
                        "' --rooms 3 --seed 4 --train-frames 2 --test-frames 1 --width 80 "
                        "--height 60 --illumination-change",
                    dir.path() / "stderr.txt"),
            0)
      << fileBytes(dir.path() / "stderr.txt");
  EXPECT_TRUE(fs::exists(out / "building.json"));
  for (const char* room : {"room-0", "room-1", "room-2"}) {
    EXPECT_TRUE(fs::exists(out / room / "test" / "frame-000000.color.png")) << room;
    const nlohmann::json scene = nlohmann::json::parse(fileBytes(out / room / "scene.json"));
    EXPECT_TRUE(scene["effects"]["illumination_change"].get<bool>()) << room;
    EXPECT_EQ(scene["camera"]["width"].get<int>(), 80) << room;
  }
}
