// synthesize: writes a synthetic RGB-D relocalization dataset (7-Scenes layout)
// of a procedurally generated room with exact ground truth, or with --rooms a
// building of such rooms.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include "cli_support.h"
#include "relocalizer/sim/building_walk.h"
#include "relocalizer/sim/synthetic_building.h"
#include "relocalizer/sim/synthetic_scene.h"

using relocalizer::cli::fail;

namespace {

// The --test-* options: changes of the world in the test frames only; --test-lamp's
// value goes to `lamp`.
void addTestChangeOptions(relocalizer::cli::App& app, relocalizer::SceneChanges& changes,
                          std::string& lamp) {
  using Changes = relocalizer::SceneChanges;
  const std::string after =
      " in the test frames only (the training frames stay those of a run without it)";
  const auto addChange = [&](const std::string& name, int& count, int most,
                             const std::string& what) {
    app.addOption(name, count, what + after)->range(0, most)->showDefault();
  };
  addChange("--test-people", changes.people, Changes::kMaxPeople,
            "People walking through the room, in colour and depth but never in the ground "
            "truth, crossing the camera's view now and then,");
  addChange("--test-moved-furniture", changes.moved_furniture, Changes::kMaxPieces,
            "Pieces of furniture (with what is on them) moved at least 0.5 m along their wall "
            "or to another wall, the poses staying exact ground truth,");
  addChange("--test-removed-objects", changes.removed_objects, Changes::kMaxObjects,
            "Wall decorations (posters, pictures, cork boards, shelves with their objects) "
            "and small things on desks and cabinets (book stacks, mugs, vases, plants, "
            "photos) taken away");
  addChange("--test-added-objects", changes.added_objects, Changes::kMaxObjects,
            "New wall decorations (new colours and textures) hung where the walls are free");
  app.addOption("--test-lamp", lamp,
                "Local light change" + after +
                    ": off switches one of the two ceiling lights off, on switches on a lamp "
                    "before what the test camera faces (that part of the room much brighter, the "
                    "rest hardly); depth "
                    "unchanged")
      ->oneOf({"none", "off", "on"})
      ->showDefault();
}

// Why a building's walk cannot be written with these options, or "".
std::string walkError(const relocalizer::SyntheticSceneOptions& options,
                      const relocalizer::BuildingWalkOptions& walk) {
  if (options.test_frames > relocalizer::kWalkTestIdsPerRoom)
    return "--test-frames: a walk holds at most " +
           std::to_string(relocalizer::kWalkTestIdsPerRoom) + " test frames per room";
  if (options.test_changes.any())
    return "--test-*: the walk is rendered without changes of the world";
  const std::string walk_invalid = walk.validationError();
  if (!walk_invalid.empty()) return "--train-frames: the walk's " + walk_invalid;
  return {};
}

}  // namespace

int main(int argc, char** argv) {
  relocalizer::cli::App app{
      "Writes a synthetic RGB-D relocalization dataset of a procedurally generated room: "
      "OUTPUT/train and OUTPUT/test in the 7-Scenes layout (frame-XXXXXX.color.png, "
      ".depth.png in millimetres, .pose.txt camera-to-world), OUTPUT/scene.json and "
      "OUTPUT/contact_sheet.png. The same seed gives byte-identical files.",
      "synthesize"};
  relocalizer::SyntheticSceneOptions options;
  std::string output;
  int width = 0, height = 0;
  app.addOption("-o,--output", output, "Folder to write (created if missing)")->required();
  app.addOption("--seed", options.seed, "Room and noise seed")->showDefault();
  app.addOption("--train-frames", options.train_frames, "Training frames")
      ->range(1, 1000000)
      ->showDefault();
  app.addOption("--test-frames", options.test_frames, "Test frames")
      ->range(0, 1000000)
      ->showDefault();
  auto* width_option =
      app.addOption("--width", width, "Image width (default 640)")->range(16, 4096);
  auto* height_option =
      app.addOption("--height", height, "Image height (default 480)")->range(16, 4096);
  width_option->needs(height_option);
  height_option->needs(width_option);
  app.addFlag("--motion-blur", options.motion_blur, "Blur colour along the camera path");
  app.addFlag("--illumination-change", options.illumination_change,
              "Vary exposure, colour cast and lights from frame to frame");
  app.addFlag("--moving-objects", options.moving_objects,
              "Add moving distractors (not part of the static ground truth)");
  std::string lamp = "none";
  addTestChangeOptions(app, options.test_changes, lamp);
  int rooms = 0;
  auto* rooms_option =
      app.addOption("--rooms", rooms,
                    "Write a building of this many rooms instead of one room: OUTPUT/room-0 ... "
                    "OUTPUT/room-(N-1), each a dataset as above (room i has seed SEED + i), and "
                    "OUTPUT/building.json (names, seeds, the look-alike pair, placement in one "
                    "building frame). The rooms differ; from 3 rooms on, the last one looks like "
                    "room-0 (the same furniture and textures, placed differently). The other "
                    "options apply to every room. Also writes OUTPUT/walk: one walk through "
                    "all rooms in the building frame (see --no-walk).")
          ->range(relocalizer::kMinBuildingRooms, relocalizer::kMaxBuildingRooms);
  bool no_walk = false;
  relocalizer::BuildingWalkOptions walk;
  app.addFlag("--no-walk", no_walk,
              "With --rooms, do not write OUTPUT/walk: one 7-Scenes folder of a walk at " +
                  std::to_string(static_cast<int>(walk.rate)) +
                  " Hz in through each room's door, once round its training loop (at least " +
                  std::to_string(relocalizer::kSyntheticLoopFrames) +
                  " frames long) and out along the corridor; rendered frames are "
                  "frame-<tick> in the building frame, room r's test frame i is frame-(" +
                  std::to_string(relocalizer::kWalkTestFirstId) + " + " +
                  std::to_string(relocalizer::kWalkTestIdsPerRoom) +
                  " r + i), walk.json says which is which, walk_poses.txt has a pose at "
                  "every tick")
      ->needs(rooms_option);

  if (const relocalizer::cli::Exit done = app.parse(argc, argv)) return *done;

  options.test_changes.lamp = *relocalizer::lampChangeFromName(lamp);  // oneOf checked it
  options.camera = relocalizer::CameraIntrinsics::kinectDefault();
  if (width > 0) options.camera = options.camera.scaledTo(width, height);
  const std::string invalid = options.validationError();
  if (!invalid.empty()) return fail(app, invalid);

  const bool building = rooms_option->count() > 0;
  walk.loop_frames = options.train_frames;
  if (building && !no_walk) {
    const std::string walk_invalid = walkError(options, walk);
    if (!walk_invalid.empty()) return fail(app, walk_invalid + " (or give --no-walk)");
  }

  const auto start = std::chrono::steady_clock::now();
  relocalizer::Status status =
      building ? relocalizer::writeSyntheticBuilding(
                     output, relocalizer::SyntheticBuildingOptions{options, rooms})
               : relocalizer::writeSyntheticScene(output, options);
  if (status && building && !no_walk) {
    const auto placed = relocalizer::buildingRooms(options.seed, rooms);
    status = placed ? relocalizer::writeBuildingWalk(output, *placed, options, walk)
                    : relocalizer::Status(relocalizer::makeError(placed.error()));
  }
  if (!status) return fail(app, status.error(), 1);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::string what =
      rooms_option->count() > 0 ? " in each of " + std::to_string(rooms) + " rooms" : "";
  std::printf("wrote %d training and %d test frames%s (%dx%d, seed %llu) to %s in %.1f s\n",
              options.train_frames, options.test_frames, what.c_str(), options.camera.width,
              options.camera.height, static_cast<unsigned long long>(options.seed), output.c_str(),
              seconds);
  if (building && !no_walk) std::printf("and a walk through them to %s/walk\n", output.c_str());
  return 0;
}
