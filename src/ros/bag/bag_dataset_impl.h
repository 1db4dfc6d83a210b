#pragma once
// What a BagDataset holds once scanned: private to bag_dataset.cpp, which reads
// the bag (topics, messages, poses) and hands its frames to bag_frames.h
// (pairing colour, depth and camera_info, and selecting the frames).

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>

#include <map>
#include <mutex>
#include <set>

#include "../conversion/message_conversion.h"
#include "bag_dataset.h"
#include "bag_frames.h"
#include "bag_poses.h"

namespace relocalizer_ros {

struct BagDataset::Impl {
  using ImageEntry = bag_internal::ImageEntry;
  using Frame = bag_internal::SyncedFrame;

  std::string path;
  BagOptions options;
  std::unique_ptr<rosbag::Bag> bag;
  mutable std::mutex bag_mutex;  // rosbag reads share one file and chunk buffer

  std::vector<rosbag::MessageInstance> messages;  // image messages, read on load()
  std::vector<ImageEntry> colour, depth;
  std::vector<sensor_msgs::CameraInfo> infos;                 // sorted by stamp
  std::map<std::string, std::pair<std::string, int>> topics;  // topic -> (type, messages)
  std::set<std::string> colour_encodings, depth_encodings;

  std::vector<Frame> synced;  // all synchronized frames, by colour stamp; id = index
  std::vector<size_t> kept;   // into synced
  PoseReport poses;
  std::string pose_child;  // Odometry / TransformStamped child_frame_id on the pose topic
  BagCounts counts;
  CameraIntrinsics camera;
  bool distorted = false;  // some kept frame's camera_info has non-zero D

  std::string where() const { return path + ": "; }
  std::string topicList() const {
    std::string text;
    for (const auto& [topic, info] : topics)
      text += (text.empty() ? "" : ", ") + topic + " (" + info.first + ", " +
              std::to_string(info.second) + (info.second == 1 ? " message)" : " messages)");
    return text.empty() ? "none" : text;
  }

  // What the pose source gave while reading the bag.
  struct PoseInputs {
    std::vector<geometry_msgs::TransformStamped> transforms;  // /tf and /tf_static
    std::vector<bool> is_static;                              // per transform
    std::vector<PoseSample> samples;                          // the pose topic
    std::string pose_type;                                    // the pose topic's message type
  };

  // Reads the bag: checkTopics, readMessages, then the frames (bag_frames.h),
  // their poses and the selection.
  relocalizer::Status scan();
  // The topics exist with the right types (from the index, no message read).
  relocalizer::Status checkTopics(std::string& pose_type);
  // One pass in bag order: image headers, camera_infos and the pose source.
  relocalizer::Status readMessages(PoseInputs& inputs);
  relocalizer::Status readPoseMessage(const rosbag::MessageInstance& m, const std::string& topic,
                                      std::vector<PoseSample>& samples,
                                      std::string& pose_frame_error);
};

}  // namespace relocalizer_ros
