#pragma once
// One synchronised set of input messages as the node received it. Holding the
// messages (not pixels) keeps the subscription callbacks O(1) and converts
// only frames that are actually used.

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

}  // namespace relocalizer_ros
