#pragma once
// Hands each accepted pose to the localizer that runs the robot: on
// `initialpose` (amcl and rtabmap take a pose there) and to robot_localization's
// SetPose service. Fed by NodeOutput's listener, so it sees exactly the answers
// users see, and only those that passed every gate (TF included).
//  - Each frame is handed off once, and never after a later frame of the same
//    timeline (a service call and the continuous worker may both answer one
//    frame, or finish out of order): a filter must not be set back in time.
//  - With handoff_frame, the pose handed off is that frame's (the robot's base:
//    what amcl and robot_localization estimate), through TF camera -> it at the
//    answer's stamp; the covariance moves with the lever arm. That lookup
//    waits up to tf_timeout, so it runs on a thread of its own with the newest
//    answer only: a handoff_frame that never resolves holds up no answer
//    (issue 38, H1: each one waited tf_timeout before it went out).
//  - The service is called on a thread of its own with the newest pose only: a
//    slow or absent service never holds up an answer, and poses that arrive
//    while a call runs replace each other.
// initialpose is published from the node's own NodeHandle, so a subscriber of
// the same topic in this node can tell its own messages by the publisher.

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "handoff_settings.h"
#include "node_output.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"
#include "throttled_log.h"

namespace relocalizer_ros {

using relocalizer::Matrix6d;
using relocalizer::Pose;

// The covariance of map_T_camera * camera_T_frame (x y z, rotation about the
// map axes) from map_T_camera's: the frame's position also moves with the
// camera's rotation, along the lever arm between them.
Matrix6d moveCovariance(const Matrix6d& covariance, const Pose& map_T_camera,
                        const Pose& camera_T_frame);

class PoseHandoff {
 public:
  // Whether the parameters ask for any hand-off at all.
  static bool wanted(const HandoffSettings& params) {
    return params.forward_initialpose || !params.set_pose_service.empty();
  }

  // `tf`: the node's buffer (relocalizer_node.h), read with handoff_frame
  // set only, on this part's own lookup thread; it outlives this.
  PoseHandoff(ros::NodeHandle nh, const HandoffSettings& params, double tf_timeout,
              tf2_ros::Buffer& tf);
  ~PoseHandoff();
  PoseHandoff(const PoseHandoff&) = delete;
  PoseHandoff& operator=(const PoseHandoff&) = delete;

  // NodeOutput's listener: runs on the answering thread and waits for
  // nothing (neither TF camera -> handoff_frame nor the service).
  void onPublished(const NodeOutput::Published& published);

 private:
  // True when the frame is later than every frame handed off so far.
  bool claim(uint64_t epoch, const ros::Time& stamp);
  // An answer's pose and the frame it is the pose of.
  struct Answer {
    geometry_msgs::PoseWithCovarianceStamped pose;
    std::string camera_frame;
  };
  // The answer's pose as handed off: handoff_frame's.
  relocalizer::Expected<geometry_msgs::PoseWithCovarianceStamped> handedPose(
      const Answer& answer) const;
  // TF camera -> handoff_frame at `stamp`, waited for up to tf_timeout in
  // short slices, so that the destructor never waits a whole tf_timeout.
  void waitForTransform(const std::string& camera_frame, const ros::Time& stamp) const;
  // The pose goes to initialpose and the service.
  void handOff(geometry_msgs::PoseWithCovarianceStamped pose);
  void lookupLoop();
  void callLoop();

  const HandoffSettings& params_;
  const double tf_timeout_;  // seconds (tf_settings.h)
  ros::NodeHandle nh_;
  ros::Publisher initialpose_pub_;
  tf2_ros::Buffer& buffer_;
  mutable ThrottledLog log_;

  std::atomic<bool> stopping_{false};

  std::mutex claim_mutex_;
  bool claimed_any_ = false;
  uint64_t last_epoch_ = 0;
  ros::Time last_stamp_;

  // The TF side (handoff_frame set only): the newest answer not yet looked up.
  std::mutex lookup_mutex_;
  std::condition_variable lookup_wake_;
  std::optional<Answer> lookup_pending_;
  std::thread looker_;

  // The service side: the newest pose not yet sent, and the client of the call
  // under way, shut down by the destructor to end a call that hangs.
  std::mutex call_mutex_;
  std::condition_variable call_wake_;
  std::optional<geometry_msgs::PoseWithCovarianceStamped> pending_;
  ros::ServiceClient client_;
  std::thread caller_;
};

}  // namespace relocalizer_ros
