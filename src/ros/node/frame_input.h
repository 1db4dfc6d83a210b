#pragma once
// One synchronised set of input messages as the node received it. Holding the
// messages (not pixels) keeps the subscription callbacks O(1) and converts
// only frames that are actually used.

#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <cstdint>
#include <memory>
#include <string>

namespace relocalizer_ros {

struct FrameInput {
  sensor_msgs::ImageConstPtr colour;
  sensor_msgs::ImageConstPtr depth;
  sensor_msgs::CameraInfoConstPtr info;
  std::string error;   // why the set cannot be a frame (checked on arrival)
  uint64_t epoch = 0;  // time jumps seen before it was synchronised
};
using FrameInputPtr = std::shared_ptr<const FrameInput>;

// The time the frame's geometry holds for: its 3D points are the depth
// image's, so a camera pose solved from them, or learned with them, is the
// pose at the depth's stamp (it can trail colour by a frame on a Kinect v1;
// test_stamps.cpp measures a turning camera).
inline ros::Time geometryStamp(const FrameInput& input) { return input.depth->header.stamp; }

}  // namespace relocalizer_ros
