#pragma once
// A procedurally generated room with exact ground truth, for tests and demos
// that must not depend on downloaded datasets. The room (about 6 x 5 x 2.8 m:
// textured walls, furniture, posters, a door, a window) and everything about
// its renders follow from one seed, so a failing test can be reproduced from
// the seed alone and files written twice are byte-identical.
//
// World frame: metres, z up, floor at z = 0, room interior is bounds().
// Camera poses are camera-to-world (pose.h) with the ROS optical camera frame
// (camera.h): x right, y down, z forward.

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"

namespace relocalizer {

// Kinect v1 depth model, shared by the renderer and the tests that check it.
// Depth comes from disparity d = fB / z quantised to 1/8 pixel at the sensor's
// native focal length, so the quantisation step grows like z^2 whatever the
// output image size.
struct KinectDepthModel {
  static constexpr double kBaselineFocal = 0.075 * 585.0;  // metres * pixels
  static constexpr double kDisparityStep = 1.0 / 8.0;      // pixels
  static constexpr double kMinDepth = 0.4;                 // metres
  static constexpr double kMaxDepth = 6.0;                 // metres

  // Standard deviation of the depth noise at depth z (metres), as measured by
  // Khoshelham & Elberink (2012) and Nguyen et al. (2012) for the Kinect v1.
  static double noiseSigma(double z) { return 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4); }
  // Depth after disparity quantisation.
  static double quantise(double z);
  // Distance between neighbouring representable depths around z.
  static double quantisationStep(double z) { return z * z * kDisparityStep / kBaselineFocal; }
};

// What a render adds on top of the static room. Defaults give a clean
// Kinect-like frame; effects that make relocalization harder are opt-in.
struct RenderEffects {
  // Kinect depth model: noise, disparity quantisation, millimetre rounding,
  // holes at depth edges, on dark or transparent surfaces and out of range.
  // Off, depth is the exact ray-cast depth of what the colour image shows.
  bool depth_noise = true;
  // Global gain, colour cast and light intensities that vary with frame_index.
  bool illumination_change = false;
  // People-sized boxes that move with frame_index. They are distractors: they
  // appear in colour and depth but never in the static ground truth
  // (exactDepth, castRay, surfaceDistance).
  bool moving_objects = false;
  // When non-empty, colour is the mean of renders from these camera poses
  // (see motionBlurPoses); depth still comes from the frame's own pose, so the
  // blur costs appearance only and the ground truth stays exact.
  std::vector<Pose> motion_blur_poses;
};

// Changes of the world after training (issue 40): what a changed room
// (SyntheticRoom::changed) differs in from its room. Each follows from the
// room's seed and the change's own count, so two runs with the same changes
// change the same things, and a change left at zero changes nothing. They go
// where the test path of the default split (SyntheticSceneOptions' frame
// counts) looks, so that its frames show them.
enum class LampChange {
  kNone,
  kOff,  // one of the two ceiling lights switched off
  kOn,   // a lamp switched on before what the test camera faces: bright there, not far off
};
struct SceneChanges {
  static constexpr int kMaxPeople = 3;
  static constexpr int kMaxPieces = 4;   // of furniture moved
  static constexpr int kMaxObjects = 6;  // decorations removed, or added
  // People walking through the free floor between the furniture and the
  // camera paths, in both directions: in colour and depth, never in the static
  // ground truth (exactDepth, castRay, surfaceDistance), like moving_objects.
  int people = 0;
  // Pieces of furniture (shelves, desks, cabinets, wardrobes, with what is on
  // them) moved at least 0.5 m along their wall or to another wall, where the
  // walls are free; they are the changed room's static world.
  int moved_furniture = 0;
  // Wall decorations (posters, pictures, cork boards, shelves with their
  // objects) and small things on desks and cabinets (book stacks, mugs,
  // vases, plants, photos) taken away.
  int removed_objects = 0;
  // New wall decorations (new colours and textures) hung where the walls are free.
  int added_objects = 0;
  LampChange lamp = LampChange::kNone;

  bool any() const;
  // Empty when usable, otherwise why not, naming the synthesize option.
  std::string validationError() const;
};
// "none", "off", "on": the names synthesize's --test-lamp takes, and back
// (nothing for another name).
std::string lampChangeName(LampChange lamp);
std::optional<LampChange> lampChangeFromName(const std::string& name);

struct SyntheticTrajectories {
  std::vector<Pose> train;
  std::vector<Pose> test;
};

// Everything writeSyntheticScene needs; scene.json records it.
struct SyntheticSceneOptions {
  uint64_t seed = 1;
  // When set (and not seed), the room is a look-alike: the furniture and
  // textures of this seed's room, placed by `seed` (see RoomRecipe).
  std::optional<uint64_t> appearance_seed;
  int train_frames = 300;
  int test_frames = 100;
  // Kinect default (640x480, f = 585); smaller images via
  // CameraIntrinsics::kinectDefault().scaledTo(320, 240).
  CameraIntrinsics camera;
  bool motion_blur = false;
  bool illumination_change = false;
  bool moving_objects = false;
  // Applied to the test frames only: the training frames are those of a run
  // without them, byte for byte.
  SceneChanges test_changes;

  // Empty when usable, otherwise why not.
  std::string validationError() const;
};

// Which room to build. A room follows from one seed; a look-alike room takes
// its shell (size, wall, floor and ceiling textures, door, window, lights) and
// every piece of furniture and decoration (sizes, colours, textures) from the
// room of appearance_seed, and puts the pieces elsewhere along the walls, drawn
// from layout_seed, which also seeds its camera paths and render noise. Equal
// seeds give exactly SyntheticRoom(seed).
struct RoomRecipe {
  uint64_t appearance_seed = 1;
  uint64_t layout_seed = 1;
};

// One static box of a room, as tests compare rooms: its pose and size, and a
// fingerprint of its faces' materials (equal for the same colours, patterns
// and texture seeds).
struct RoomBox {
  Eigen::Vector3d centre;
  Eigen::Vector3d half_size;  // along the box's own axes
  double yaw = 0;             // radians about z
  uint64_t appearance = 0;
};

// The room's one door, on one of its walls: where a walk through a building
// enters and leaves it (building_walk.h).
struct RoomDoor {
  Eigen::Vector3d centre;  // middle of the door leaf, on the wall's plane
  Eigen::Vector3d inward;  // unit normal of its wall, pointing into the room
  double width = 0, height = 0;
};

// trajectories() of at least this many training frames go once all round the
// loop, and the pose after the last would be the first again.
constexpr int kSyntheticLoopFrames = 280;

// The room is built once (well under a millisecond) and never changes, so
// copies are cheap and every const method may run on many threads at once.
class SyntheticRoom {
 public:
  explicit SyntheticRoom(uint64_t seed);
  explicit SyntheticRoom(const RoomRecipe& recipe);

  // The layout seed: seed() == appearanceSeed() but in a look-alike room.
  uint64_t seed() const;
  uint64_t appearanceSeed() const;
  // The room's interior (walls, floor and ceiling are its faces).
  Eigen::AlignedBox3d bounds() const;
  // Static boxes (furniture, books, frames, ...) besides the room shell.
  int boxCount() const;
  // The door (a look-alike room keeps its original's).
  RoomDoor door() const;
  // Those boxes, in the order they were built.
  std::vector<RoomBox> boxes() const;

  // One RGB-D frame seen from camera_to_world. frame_index is the frame's time:
  // it seeds the depth noise and drives the optional effects, so the same
  // arguments always give the same images. Depth is metres with NaN holes and,
  // with depth noise on, holds exactly the values that the 16-bit millimetre
  // file written by depthToMillimetres reads back as through depthToMetres.
  // ground_truth is camera_to_world, id is frame_index. Unusable intrinsics
  // throw std::invalid_argument (a programming error, as elsewhere).
  RgbdFrame render(const Pose& camera_to_world, const CameraIntrinsics& camera, int frame_index,
                   const RenderEffects& effects = {}) const;

  // Noiseless depth (metres along the optical axis) of the static room: the
  // ground truth that back-projects exactly onto the room's surfaces.
  cv::Mat exactDepth(const Pose& camera_to_world, const CameraIntrinsics& camera) const;

  // Distance along `direction` (need not be unit length; the result is in
  // units of its length) from `origin`, which must be inside the room, to the
  // first static surface; nothing for an origin outside or a zero direction.
  std::optional<double> castRay(const Eigen::Vector3d& origin,
                                const Eigen::Vector3d& direction) const;

  // Unsigned distance from a point inside the room to the nearest static
  // surface. Computed from the box shapes independently of the ray caster, so
  // tests can check the ray caster against it.
  double surfaceDistance(const Eigen::Vector3d& point) const;

  // Smooth camera paths through the room's interior, looking outward at the
  // walls and furniture from 1-2.5 m. Training goes round a loop (all headings
  // once it has >= kSyntheticLoopFrames frames, an arc of it otherwise); the test path is a
  // different loop (smaller radius, higher, different wobble) laid along the
  // part of the room the training path sees, so relocalization is possible.
  // Consecutive frames are ~1-3 cm and ~1-2 degrees apart (closer when there
  // are more frames than that).
  SyntheticTrajectories trajectories(int train_frames, int test_frames) const;

  // This room after `changes`: the same seeds, shell, camera paths and depth
  // noise, with furniture moved, objects taken away, decorations added, a light
  // switched and people walking through. boxes() of the changed room lists
  // its boxes in the original's order, those taken away left out and those
  // added at the end. Unusable changes throw std::invalid_argument.
  SyntheticRoom changed(const SceneChanges& changes) const;
  // What changed() made of this room: as asked, but fewer pieces where the
  // room has fewer or finds no free place for more (people at most kMaxPeople);
  // nothing for a room as built.
  SceneChanges changes() const;

  struct Impl;  // public only so the builder in the .cpp can fill it in

 private:
  std::shared_ptr<const Impl> impl_;  // immutable after construction, so shared
};

// Sub-exposure camera poses for motion blur of path[index]: `samples` poses
// spread over `exposure` frame intervals centred on the frame, interpolated
// along the path (linear in position, slerp in rotation).
std::vector<Pose> motionBlurPoses(const std::vector<Pose>& path, size_t index, int samples = 5,
                                  double exposure = 0.5);

// Writes a synthetic dataset in the 7-Scenes layout:
//   output_dir/train/ and output_dir/test/ with frame-XXXXXX.color.png (8-bit
//   BGR), frame-XXXXXX.depth.png (16-bit mm, 0 = invalid),
//   frame-XXXXXX.pose.txt (4x4 camera-to-world), camera-intrinsics.txt (K) and
//   colour-registration.txt ("registered": colour and depth share one camera);
//   output_dir/scene.json (the options and room facts) and
//   output_dir/contact_sheet.png (a few frames, colour beside colourised depth).
// Test frame i is rendered at time train_frames + i, as if recorded after the
// training sequence. Frames of an earlier, longer run in the same folders are
// removed. Shows a ProgressBar on a terminal.
Status writeSyntheticScene(const std::string& output_dir, const SyntheticSceneOptions& options);

}  // namespace relocalizer
