#pragma once
// Where accepted poses are handed to the robot's localizer (pose_handoff.h).

#include <string>

#include "param_reading.h"

namespace relocalizer_ros {

struct HandoffSettings {
  bool forward_initialpose = false;  // publish each accepted pose on initialpose (amcl, rtabmap)
  std::string set_pose_service;      // call this robot_localization SetPose service ("": none)
  std::string handoff_frame;         // hand off this frame's pose, not the camera's ("": camera)
};

// forward_initialpose, set_pose_service, handoff_frame (leading slashes dropped).
void readHandoffSettings(ParamReader& reader, HandoffSettings& handoff);

}  // namespace relocalizer_ros
