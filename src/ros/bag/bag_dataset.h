#pragma once
// A rosbag as a dataset: the RGB-D frames of a recording, with camera poses
// from the bag's TF (as a SLAM stack publishes them) or from a pose topic, as
// the same RgbdFrames the folder readers give (dataset.h). Every tool's --bag
// reads bags through it (frame_sources.h).
//
// Frames: colour, depth and camera_info messages (sensor_msgs/Image,
// sensor_msgs/Image, sensor_msgs/CameraInfo) are associated by header stamp:
// each colour image takes the depth image nearest in time (one to one, nearest
// pairs first, as TUM's associate.py) and the nearest camera_info, both within
// sync_tolerance. Frames are ordered by colour stamp; a frame's id is its index
// in that order (so ids name the same frames whatever poses, selection or key
// frames are chosen), its stamp the colour stamp in seconds.
//
// Poses (camera-to-map, pose.h):
//  - TF (default): /tf and /tf_static of the whole bag fill a tf2::BufferCore
//    whose cache spans the recording; the pose is map_frame -> camera frame at
//    the colour stamp, interpolated by tf2. The camera frame is camera_frame or
//    the colour image's header frame_id.
//  - pose_topic: geometry_msgs/PoseStamped, PoseWithCovarianceStamped or
//    nav_msgs/Odometry giving the camera's pose in map_frame, interpolated
//    (linear in position, slerp in rotation) at the colour stamp.
//  Either way a frame has a pose "in time" only when every pose stream it
//  needs (the pose topic, or each non-static TF edge on the path from the map
//  frame to the camera) has a sample at most pose_tolerance before or at the
//  stamp and one at most pose_tolerance after or at it. Frames without are
//  skipped and counted: that is how SLAM tracking losses (gaps in its poses)
//  stay out of training, and nothing is ever extrapolated.
//
// Selection: `frames` (FrameSelection over ids), then key frames among the
// frames with a pose: a frame is kept when it moved at least min_translation
// metres or min_rotation_degrees from the last kept frame (the first is kept).
//
// Images are read when load() asks for them, so memory does not grow with the
// recording's length; headers, camera_info and poses are read at open time, so
// a bad bag fails at once.

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"

namespace relocalizer_ros {

using relocalizer::CameraIntrinsics;
using relocalizer::Expected;
using relocalizer::Pose;
using relocalizer::RgbdFrame;

struct BagOptions {
  // Topic names as make_bag writes them.
  std::string rgb_topic = "/camera/rgb/image_raw";
  std::string depth_topic = "/camera/depth/image_raw";
  std::string camera_info_topic = "/camera/rgb/camera_info";
  // Largest stamp difference between a colour image and its depth image or
  // camera_info, seconds (TUM's associate.py uses 0.02).
  double sync_tolerance = 0.02;
  // Empty: poses from /tf and /tf_static; otherwise a PoseStamped,
  // PoseWithCovarianceStamped or Odometry topic.
  std::string pose_topic;
  // The model's world frame: TF lookups start here; a pose topic must be in it.
  std::string map_frame = "map";
  // Empty: each colour image's header frame_id.
  std::string camera_frame;
  // Largest distance in time to the pose samples around a stamp, seconds.
  double pose_tolerance = 0.1;
  // FrameSelection expression over frame ids ("" = all), e.g. "0-99,200-299".
  std::string frames;
  // Key-frame selection; both 0 keeps every frame with a pose.
  double min_translation = 0.0;       // metres
  double min_rotation_degrees = 0.0;  // degrees
};

// What open() found, for summaries and tests.
struct BagCounts {
  int colour_images = 0;
  int depth_images = 0;
  int camera_infos = 0;
  int synchronized = 0;          // frames with colour + depth + camera_info
  int colour_without_depth = 0;  // colour images with no depth within sync_tolerance
  int colour_without_info = 0;   // ... with depth but no camera_info within sync_tolerance
  int selected = 0;              // synchronized frames inside `frames`
  int with_pose = 0;             // selected frames with a pose in time
  int without_pose = 0;          // selected frames skipped: no pose in time
  int key_frames = 0;            // frames kept (with a pose, after key-frame selection)
  int tf_transforms = 0;         // /tf + /tf_static transforms read
  int tf_ignored = 0;            // of those: repeated stamps, NaN, empty or self frames
  int pose_samples = 0;          // pose topic messages used
  int pose_samples_ignored = 0;  // pose topic messages with non-finite poses
};

class BagDataset {
 public:
  // Fails, never throws, with a message naming the bag and the topic or frame
  // at fault: a bag that cannot be opened, an empty bag, a missing topic (with
  // the topics the bag has), a topic of the wrong type, an unsupported image
  // encoding, no TF path between the map and camera frames (with the TF trees
  // the bag has), a pose topic in another frame, or no frame left to use.
  static Expected<std::unique_ptr<BagDataset>> open(const std::string& path,
                                                    const BagOptions& options = {});
  ~BagDataset();
  BagDataset(const BagDataset&) = delete;
  BagDataset& operator=(const BagDataset&) = delete;

  // Kept frames (selected, with a pose, key frames), in increasing id.
  size_t size() const;
  // Index of the i-th kept frame among the bag's synchronized frames. Throws
  // std::out_of_range for i >= size(), as Dataset does.
  int id(size_t i) const;
  // Colour stamp, seconds. Throws like id().
  double stamp(size_t i) const;
  // Camera-to-map pose (always set for kept frames). Throws like id().
  const std::optional<Pose>& groundTruth(size_t i) const;
  // Reads and converts the i-th kept frame (message_conversion.h), with id,
  // stamp and pose set. Thread-safe (bag reads are serialised, conversion is
  // not); failures name the bag, topics and stamp.
  Expected<RgbdFrame> load(size_t i) const;

  // Intrinsics of the first kept frame.
  const CameraIntrinsics& camera() const;
  const std::string& path() const;
  // "TF map -> camera_rgb_optical_frame" or "topic /slam/pose (geometry_msgs/PoseStamped)".
  const std::string& poseSource() const;
  const BagCounts& counts() const;
  // Several lines in the style of Dataset::summary(): bag, topics, frames
  // found, synchronized, skipped without a pose, key-frame selection, kept
  // ids, image size, intrinsics and path length.
  std::string summary() const;

  struct Impl;

 private:
  explicit BagDataset(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace relocalizer_ros
