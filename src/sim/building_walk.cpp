// The walk through a synthetic building and its 7-Scenes folder.

#include "relocalizer/sim/building_walk.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "dataset_files.h"
#include "relocalizer/core/progress.h"

namespace relocalizer {
namespace {

namespace fs = std::filesystem;

// How far into a room the walk goes straight from its door before turning
// towards the loop: past the furniture along the walls (at most ~0.65 m deep).
constexpr double kHallDepth = 1.2;
// The corridor is walked along its middle.
constexpr double kCorridorY = (kCorridorNearY + kCorridorFarY) / 2;
constexpr double kDegree = M_PI / 180.0;
// Every id fits the 6 digits of frame-XXXXXX names, whatever the building.
static_assert(kWalkTestFirstId + kWalkTestIdsPerRoom * kMaxBuildingRooms <= 1000000);

double yawOf(const Pose& pose) {
  const Eigen::Vector3d forward = pose.linear().col(2);
  return std::atan2(forward.y(), forward.x());
}

// A camera at `position` looking horizontally along `yaw` (radians about z
// from +x), upright: the loops' convention (room_trajectories.cpp) at zero
// pitch and roll.
Pose levelPose(const Eigen::Vector3d& position, double yaw) {
  const Eigen::Vector3d forward(std::cos(yaw), std::sin(yaw), 0);
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  Pose pose = Pose::Identity();
  pose.linear().col(0) = right;
  pose.linear().col(1) = forward.cross(right);
  pose.linear().col(2) = forward;
  pose.translation() = position;
  return pose;
}

// Appends ticks that move in steps within the options' limits.
class WalkBuilder {
 public:
  explicit WalkBuilder(const BuildingWalkOptions& options)
      : max_metres_(options.max_step_metres), max_radians_(options.max_step_degrees * kDegree) {}

  void start(const Pose& pose, int room) { ticks_.push_back({pose, room, false}); }

  // Straight there, position lerped and rotation slerped together.
  void moveTo(const Pose& to, int room) {
    const Pose from = ticks_.back().building_pose;
    const double metres = (to.translation() - from.translation()).norm();
    const Eigen::Quaterniond q0(from.linear()), q1(to.linear());
    const double radians = q0.angularDistance(q1);
    const int steps =
        static_cast<int>(std::ceil(std::max(metres / max_metres_, radians / max_radians_)));
    for (int k = 1; k <= steps; ++k) {
      const double f = static_cast<double>(k) / steps;
      Pose pose = Pose::Identity();
      pose.linear() = q0.slerp(f, q1).toRotationMatrix();
      pose.translation() = (1 - f) * from.translation() + f * to.translation();
      ticks_.push_back({k == steps ? to : pose, room, false});
    }
  }

  // On the spot about z, the short way round: slerp would tip the camera
  // over on a half turn. The last tick must be level.
  void turnTo(double yaw, int room) {
    const Pose from = ticks_.back().building_pose;
    const double yaw0 = yawOf(from);
    const double turn = std::remainder(yaw - yaw0, 2 * M_PI);
    const int steps = static_cast<int>(std::ceil(std::abs(turn) / max_radians_));
    for (int k = 1; k <= steps; ++k)
      ticks_.push_back({levelPose(from.translation(), yaw0 + turn * k / steps), room, false});
  }

  std::vector<WalkTick>& ticks() { return ticks_; }

 private:
  double max_metres_, max_radians_;
  std::vector<WalkTick> ticks_;
};

bool insideShrunk(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& point, double margin) {
  const Eigen::Vector3d m = Eigen::Vector3d::Constant(margin);
  return (point.array() > (box.min() + m).array()).all() &&
         (point.array() < (box.max() - m).array()).all();
}

// What walk.json says of one room.
struct RoomSpan {
  int first = -1, last = -1, first_rendered = -1, last_rendered = -1, rendered = 0;
};

std::vector<RoomSpan> roomSpans(const std::vector<WalkTick>& ticks, size_t rooms) {
  std::vector<RoomSpan> spans(rooms);
  for (int t = 0; t < static_cast<int>(ticks.size()); ++t) {
    RoomSpan& span = spans[ticks[t].room];
    if (span.first < 0) span.first = t;
    span.last = t;
    if (!ticks[t].rendered) continue;
    if (span.first_rendered < 0) span.first_rendered = t;
    span.last_rendered = t;
    ++span.rendered;
  }
  return spans;
}

std::string tumLine(double stamp, const Pose& pose) {
  const Eigen::Quaterniond q(pose.linear());
  const Eigen::Vector3d t = pose.translation();
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", stamp, t.x(),
                t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  return buffer;
}

// A test image of a room into the walk: a hard link, or a copy where the file
// system has none.
Status linkOrCopy(const fs::path& from, const fs::path& to) {
  std::error_code error;
  fs::create_hard_link(from, to, error);
  if (!error) return okStatus();
  fs::copy_file(from, to, fs::copy_options::overwrite_existing, error);
  if (error) return makeError("cannot link or copy " + from.string() + ": " + error.message());
  return okStatus();
}

}  // namespace

std::string BuildingWalkOptions::validationError() const {
  if (!(rate > 0) || !std::isfinite(rate)) return "rate must be positive";
  if (!(max_step_metres > 0.001) || !std::isfinite(max_step_metres))
    return "max_step_metres must be above 0.001";
  if (!(max_step_degrees > 0.1) || !std::isfinite(max_step_degrees))
    return "max_step_degrees must be above 0.1";
  if (!(render_margin >= 0) || !(render_margin < 1))
    return "render_margin must be in [0, 1) metres";
  if (loop_frames < 1 || loop_frames > kWalkTestFirstId / 4)
    return "loop_frames must be in [1, " + std::to_string(kWalkTestFirstId / 4) + "]";
  return {};
}

std::vector<WalkTick> buildingWalk(const std::vector<BuildingRoom>& rooms,
                                   const BuildingWalkOptions& options) {
  if (!options.validationError().empty()) return {};
  WalkBuilder walk(options);
  const int loop_frames = std::max(options.loop_frames, kSyntheticLoopFrames);
  std::vector<Eigen::AlignedBox3d> bounds;  // each room's, in its own frame
  for (int r = 0; r < static_cast<int>(rooms.size()); ++r) {
    const BuildingRoom& room = rooms[r];
    const SyntheticRoom built(room.recipe);
    bounds.push_back(built.bounds());
    std::vector<Pose> loop = built.trajectories(loop_frames, 0).train;
    for (Pose& pose : loop) pose = room.room_to_building * pose;
    const double height = loop.front().translation().z();
    const Eigen::Vector3d door(room.door.centre.x(), 0.0, height);
    const Eigen::Vector3d corridor(door.x(), kCorridorY, height);
    const Eigen::Vector3d hall = door + kHallDepth * room.door.inward;
    // Onto the loop where it passes nearest the door, round, and off there.
    size_t entry = 0;
    for (size_t i = 1; i < loop.size(); ++i)
      if ((loop[i].translation() - hall).norm() < (loop[entry].translation() - hall).norm())
        entry = i;
    if (r == 0) {
      walk.start(levelPose(corridor, M_PI / 2), r);
    } else {
      walk.turnTo(0.0, r);  // along the corridor, towards +x
      walk.moveTo(levelPose(corridor, 0.0), r);
      walk.turnTo(M_PI / 2, r);
    }
    walk.moveTo(levelPose(hall, M_PI / 2), r);
    walk.turnTo(yawOf(loop[entry]), r);
    walk.moveTo(loop[entry], r);
    for (size_t k = 1; k <= loop.size(); ++k) walk.moveTo(loop[(entry + k) % loop.size()], r);
    walk.moveTo(levelPose(hall, yawOf(loop[entry])), r);
    walk.turnTo(-M_PI / 2, r);
    walk.moveTo(levelPose(corridor, -M_PI / 2), r);
  }
  std::vector<WalkTick>& ticks = walk.ticks();
  for (WalkTick& tick : ticks) {
    const BuildingRoom& room = rooms[tick.room];
    const Eigen::Vector3d in_room =
        room.room_to_building.inverse() * tick.building_pose.translation();
    tick.rendered = insideShrunk(bounds[tick.room], in_room, options.render_margin);
  }
  return std::move(ticks);
}

Status writeBuildingWalk(const std::string& building_folder, const std::vector<BuildingRoom>& rooms,
                         const SyntheticSceneOptions& scene, const BuildingWalkOptions& options) {
  const std::string invalid = options.validationError();
  if (!invalid.empty()) return makeError("building walk options: " + invalid);
  const std::string scene_invalid = scene.validationError();
  if (!scene_invalid.empty()) return makeError("synthetic scene options: " + scene_invalid);
  if (scene.test_frames > kWalkTestIdsPerRoom)
    return makeError("a walk holds at most " + std::to_string(kWalkTestIdsPerRoom) +
                     " test frames per room, got " + std::to_string(scene.test_frames));
  if (rooms.empty()) return makeError("a walk needs rooms");
  const std::vector<WalkTick> ticks = buildingWalk(rooms, options);
  if (static_cast<long long>(ticks.size()) > kWalkTestFirstId)
    return makeError("the walk takes " + std::to_string(ticks.size()) + " ticks, more than the " +
                     std::to_string(kWalkTestFirstId) + " ids below its test frames");

  const fs::path root = fs::path(building_folder) / kWalkFolder;
  std::error_code error;
  fs::remove_all(root, error);
  if (error) return makeError("cannot remove " + root.string() + ": " + error.message());
  fs::create_directories(root, error);
  if (error) return makeError("cannot create " + root.string() + ": " + error.message());
  if (const Status written = synthetic::writeCameraFiles(root, scene.camera); !written)
    return written;

  std::vector<SyntheticRoom> built;
  for (const BuildingRoom& room : rooms) built.emplace_back(room.recipe);
  std::vector<int> rendered;
  for (int t = 0; t < static_cast<int>(ticks.size()); ++t)
    if (ticks[t].rendered) rendered.push_back(t);
  std::vector<std::string> errors(rendered.size());
  ProgressBar progress("walk", rendered.size());
  tbb::parallel_for(size_t{0}, rendered.size(), [&](size_t j) {
    const int t = rendered[j];
    const int r = ticks[t].room;
    const Eigen::Isometry3d building_to_room = rooms[r].room_to_building.inverse();
    RenderEffects effects;
    effects.illumination_change = scene.illumination_change;
    effects.moving_objects = scene.moving_objects;
    if (scene.motion_blur) {
      std::vector<Pose> near;
      for (int n = std::max(t - 1, 0); n <= std::min<int>(t + 1, ticks.size() - 1); ++n)
        near.push_back(building_to_room * ticks[n].building_pose);
      effects.motion_blur_poses = motionBlurPoses(near, t > 0 ? 1 : 0);
    }
    const RgbdFrame frame =
        built[r].render(building_to_room * ticks[t].building_pose, scene.camera, t, effects);
    const Status written = synthetic::writeFrameFiles((root / synthetic::frameStem(t)).string(),
                                                      frame, ticks[t].building_pose);
    if (!written) errors[j] = written.error();
    progress.advance();
  });
  progress.finish();
  for (const std::string& message : errors)
    if (!message.empty()) return makeError(message);

  // The rooms' test frames, as each room's own folder holds them.
  for (int r = 0; r < static_cast<int>(rooms.size()); ++r) {
    const std::vector<Pose> test =
        built[r].trajectories(scene.train_frames, scene.test_frames).test;
    const fs::path from = fs::path(building_folder) / rooms[r].name / "test";
    for (int i = 0; i < static_cast<int>(test.size()); ++i) {
      const std::string source = (from / synthetic::frameStem(i)).string();
      const std::string target =
          (root / synthetic::frameStem(kWalkTestFirstId + kWalkTestIdsPerRoom * r + i)).string();
      for (const char* suffix : {".color.png", ".depth.png"})
        if (const Status linked = linkOrCopy(source + suffix, target + suffix); !linked)
          return linked;
      if (!synthetic::writeText(target + ".pose.txt",
                                synthetic::poseText(rooms[r].room_to_building * test[i])))
        return makeError("cannot write " + target + ".pose.txt");
    }
  }

  std::string tum =
      "# camera-to-building at every tick of the walk: stamp (tick / rate) tx ty tz qx qy qz qw\n";
  for (size_t t = 0; t < ticks.size(); ++t)
    tum += tumLine(t / options.rate, ticks[t].building_pose);
  if (!synthetic::writeText(root / "walk_poses.txt", tum))
    return makeError("cannot write " + (root / "walk_poses.txt").string());

  const std::vector<RoomSpan> spans = roomSpans(ticks, rooms.size());
  nlohmann::ordered_json room_list = nlohmann::ordered_json::array();
  for (size_t r = 0; r < rooms.size(); ++r) {
    const RoomSpan& s = spans[r];
    const int first_test = kWalkTestFirstId + kWalkTestIdsPerRoom * static_cast<int>(r);
    nlohmann::ordered_json json;
    json["name"] = rooms[r].name;
    json["ticks"] = {s.first, s.last};
    json["rendered_ticks"] = {s.first_rendered, s.last_rendered};
    json["rendered"] = s.rendered;
    json["exit_tick"] = s.last_rendered;
    json["test_ids"] =
        scene.test_frames > 0
            ? nlohmann::ordered_json({first_test, first_test + scene.test_frames - 1})
            : nlohmann::ordered_json::array();
    room_list.push_back(json);
  }
  nlohmann::ordered_json json;
  json["generator"] = "relocalizer synthetic building walk";
  json["format_version"] = 1;
  json["rate"] = options.rate;
  json["ticks"] = ticks.size();
  json["rendered"] = rendered.size();
  json["max_step_metres"] = options.max_step_metres;
  json["max_step_degrees"] = options.max_step_degrees;
  json["render_margin"] = options.render_margin;
  json["loop_frames"] = std::max(options.loop_frames, kSyntheticLoopFrames);
  json["frames"] =
      "frame-<tick>: rendered ticks (inside a room), camera-to-building poses; frame-(" +
      std::to_string(kWalkTestFirstId) + " + " + std::to_string(kWalkTestIdsPerRoom) +
      " r + i): test frame i of room r, re-posed into the building frame";
  json["ranges"] = "inclusive [first, last]; exit_tick: the last rendered tick in the room";
  json["rooms"] = room_list;
  if (!synthetic::writeText(root / "walk.json", json.dump(2) + "\n"))
    return makeError("cannot write " + (root / "walk.json").string());
  return okStatus();
}

}  // namespace relocalizer
