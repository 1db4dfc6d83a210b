#pragma once
// A synthetic building for tests and demos of telling places apart: rooms
// that differ, and from three rooms on two that look alike (the same
// furniture and textures, placed differently), each written as a complete
// synthetic dataset, placed side by side in one building frame.

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/sim/synthetic_scene.h"

namespace relocalizer {

constexpr int kMinBuildingRooms = 2;
constexpr int kMaxBuildingRooms = 100;

struct BuildingRoom {
  std::string name;  // room-0, room-1, ...: also its folder in the building's folder
  RoomRecipe recipe;
  int looks_like = -1;  // index of the other room of the look-alike pair, or -1
  // From the room's own frame (SyntheticRoom's world frame) to the building's.
  Eigen::Isometry3d room_to_building = Eigen::Isometry3d::Identity();
  Eigen::AlignedBox3d bounds_in_building;
  RoomDoor door;  // in the building frame: inward is +y, the sill on y = 0
};

// The rooms of the building of `seed`. Room i has seed seed + i (wrapping), so
// room-0 is the single room `synthesize --seed SEED` writes. With three rooms
// or more, the last one is room-0's look-alike: room-0's appearance with its
// own seed as layout seed. Rooms stand in a row along the building's x axis,
// kBuildingWallThickness apart, floors at z = 0, each turned about z by a
// multiple of 90 degrees so that its door's wall faces -y and lies on y = 0,
// opening onto the corridor. Only the placement differs from the room alone:
// in its own frame each room is exactly SyntheticRoom(recipe). A count outside
// [kMinBuildingRooms, kMaxBuildingRooms] is an error naming it.
Expected<std::vector<BuildingRoom>> buildingRooms(uint64_t seed, int rooms);

// The gap between neighbouring rooms in the building frame (metres).
constexpr double kBuildingWallThickness = 0.2;
// The corridor in front of the doors, y in [kCorridorFarY, kCorridorNearY]
// along the row of rooms: walked through, never rendered.
constexpr double kCorridorNearY = -kBuildingWallThickness;
constexpr double kCorridorFarY = -1.6;
// The corridor's box along the whole row of rooms, as high as the highest.
Eigen::AlignedBox3d buildingCorridor(const std::vector<BuildingRoom>& rooms);

// Where a building's walk (building_walk.h) goes: folder/kWalkFolder.
inline const char* const kWalkFolder = "walk";

struct SyntheticBuildingOptions {
  // scene.seed is the building's seed; the other options apply to every room.
  SyntheticSceneOptions scene;
  int rooms = 3;

  // Empty when usable, otherwise why not.
  std::string validationError() const;
};

// Writes folder/<room name>/ for every room (a dataset as writeSyntheticScene
// writes it) and folder/building.json (format 2) naming the rooms (name,
// folder, seeds, the look-alike pair, each room's placement, bounds and door
// in the building frame) and the corridor. Room folders of an earlier, larger
// building in the same folder are removed, and so is an earlier walk (its
// frames are of rooms that may have changed); writeBuildingWalk writes one.
Status writeSyntheticBuilding(const std::string& folder, const SyntheticBuildingOptions& options);

}  // namespace relocalizer
