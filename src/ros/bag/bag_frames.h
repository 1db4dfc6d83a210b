#pragma once
// A scanned bag's frames: colour, depth and camera_info paired by nearest
// stamps, the pose queries of the pairs, and the frame selection. Private to
// the bag reader.

#include <sensor_msgs/CameraInfo.h>

#include <optional>
#include <string>
#include <vector>

#include "bag_dataset.h"
#include "bag_poses.h"

namespace relocalizer_ros {
namespace bag_internal {

// One image message as the scan saw it; pixels stay in the bag.
struct ImageEntry {
  ros::Time stamp;
  std::string frame_id;
  uint32_t width = 0, height = 0;
  size_t message = 0;  // index into BagDataset::Impl::messages
};

// A colour image with its depth image and camera_info.
struct SyncedFrame {
  int id = -1;
  size_t colour = 0, depth = 0, info = 0;  // into the colour, depth and camera_info lists
  std::optional<Pose> pose;
};

// Sorts `colour`, `depth` and `infos` by stamp and appends to `synced` each
// colour image with its depth image and camera_info within
// options.sync_tolerance (id = index), counting in `counts` the colour images
// left without. An error (prefixed by `where`) when depth is not registered to
// colour or when no frame pairs up.
relocalizer::Status synchronizeFrames(std::vector<ImageEntry>& colour,
                                      std::vector<ImageEntry>& depth,
                                      std::vector<sensor_msgs::CameraInfo>& infos,
                                      const BagOptions& options, const std::string& where,
                                      BagCounts& counts, std::vector<SyncedFrame>& synced);

// The pose each synchronized frame needs: its colour stamp in its camera frame
// (options.camera_frame, or else the colour image's frame).
std::vector<PoseQuery> poseQueries(const std::vector<SyncedFrame>& synced,
                                   const std::vector<ImageEntry>& colour,
                                   const BagOptions& options);

// Into `kept`, the frames of options.frames with a pose that the key-frame
// rule keeps, counting in `counts`. An error (prefixed by `where`) when the
// selection matches no frame or none of it has a pose (`poses` says where
// poses came from).
relocalizer::Status selectFrames(const std::vector<SyncedFrame>& synced,
                                 const std::vector<ImageEntry>& colour, const BagOptions& options,
                                 const PoseReport& poses, const std::string& where,
                                 BagCounts& counts, std::vector<size_t>& kept);

}  // namespace bag_internal
}  // namespace relocalizer_ros
