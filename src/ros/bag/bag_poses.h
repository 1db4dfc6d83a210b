#pragma once
// Camera poses for the frames of a recording, at their colour stamps, from the
// bag's TF (interpolated by tf2) or from a pose topic (interpolated here). A
// frame gets a pose only when every pose stream it needs has samples at most
// the tolerance before and after its stamp: nothing is ever extrapolated, so
// gaps in SLAM's poses (tracking losses) stay out of training.

#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>

#include <optional>
#include <string>
#include <vector>

#include "bag_dataset.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"

namespace relocalizer_ros {

// One frame whose pose is wanted; `pose` is filled when it has one in time.
struct PoseQuery {
  int id = -1;               // for messages
  std::string camera_frame;  // without leading slashes (TF only)
  ros::Time stamp;
  std::optional<Pose> pose;
};

// One sample of a pose topic: the camera's pose in the map frame.
struct PoseSample {
  ros::Time stamp;
  Pose pose;
};

// What the pose source held, for the bag summary and for the error when no
// frame has a pose.
struct PoseReport {
  std::string source;        // "TF map -> camera_rgb_optical_frame", "topic /slam/pose (...)"
  std::string detail;        // "1200 transforms on /tf + /tf_static", "300 samples"
  std::string no_pose_hint;  // why the first frame without a pose had none
  ros::Time begin, end;      // time span of the pose samples (zero: none)
};

// Poses map_frame -> each query's camera frame from /tf and /tf_static
// (`is_static[i]` for transforms[i]). Fails, naming the frames the bag does
// have, when no TF path joins the map frame and a camera frame. Counts the
// transforms read and ignored (repeated stamps, NaN, empty or self frames) in
// `counts`. `where` prefixes errors.
relocalizer::Status posesFromTf(const std::vector<geometry_msgs::TransformStamped>& transforms,
                                const std::vector<bool>& is_static, const BagOptions& options,
                                const std::string& where, std::vector<PoseQuery>& queries,
                                PoseReport& report, BagCounts& counts);

// Poses from the samples of options.pose_topic (message type `type`), linear
// in position and slerp in rotation between the samples around each stamp.
// `pose_child` is the frame the samples locate (Odometry, TransformStamped;
// empty when the type does not say): it must be each query's camera frame.
relocalizer::Status posesFromTopic(std::vector<PoseSample> samples, const std::string& type,
                                   const std::string& pose_child, const BagOptions& options,
                                   const std::string& where, std::vector<PoseQuery>& queries,
                                   PoseReport& report, const BagCounts& counts);

}  // namespace relocalizer_ros
