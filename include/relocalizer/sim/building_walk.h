#pragma once
// One continuous walk through a synthetic building (synthetic_building.h), in
// the building's frame, as a robot that learns the whole building online
// would make it: in through each room's door, once round the room's training
// loop, out again and along the corridor to the next door. Every tick has a
// pose (what SLAM would give, corridor included); ticks inside a room are
// also rendered.

#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/sim/synthetic_building.h"
#include "relocalizer/sim/synthetic_scene.h"

namespace relocalizer {

struct WalkTick {
  Pose building_pose;  // camera-to-building
  // The room whose door the walk is heading for, is inside or is leaving.
  int room = 0;
  // Inside that room, more than render_margin from every wall, floor and ceiling.
  bool rendered = false;
};

struct BuildingWalkOptions {
  double rate = 30;  // ticks per second
  // No two ticks further apart than these (the corridor is walked at
  // rate * max_step_metres, 0.75 m/s by default).
  double max_step_metres = 0.025;
  double max_step_degrees = 2.0;
  double render_margin = 0.25;  // metres
  // Each room's loop is its trajectories(loop_frames, 0) training path, once
  // round; fewer than kSyntheticLoopFrames make an arc, so that many are taken.
  int loop_frames = 300;

  // Empty when usable, otherwise why not.
  std::string validationError() const;
};

// The walk through `rooms` (buildingRooms), tick by tick: it starts in the
// corridor in front of room-0's door and ends there in front of the last
// room's. Options that are not usable give no ticks.
std::vector<WalkTick> buildingWalk(const std::vector<BuildingRoom>& rooms,
                                   const BuildingWalkOptions& options);

// Test frame i of room r is frame kWalkTestFirstId + kWalkTestIdsPerRoom * r + i
// of the walk's folder; rendered ticks keep their tick number as id, below it.
constexpr int kWalkTestFirstId = 500000;
constexpr int kWalkTestIdsPerRoom = 1000;

// Writes building_folder/kWalkFolder as one 7-Scenes folder, so that one
// dataset holds what is learned and what is tested: every rendered tick as
// frame-<tick> (camera-to-building pose, time = tick for the render's noise
// and effects), every room's test frames (room folders written by
// writeSyntheticBuilding with `scene`, whose images are hard-linked, copied
// where links fail) re-posed into the building frame, camera files, walk.json
// (per room: its ticks, rendered ticks, exit tick and test ids) and
// walk_poses.txt (TUM: tick / rate, position, quaternion; every tick). An
// earlier walk there is replaced. Shows a ProgressBar on a terminal.
Status writeBuildingWalk(const std::string& building_folder, const std::vector<BuildingRoom>& rooms,
                         const SyntheticSceneOptions& scene, const BuildingWalkOptions& options);

}  // namespace relocalizer
