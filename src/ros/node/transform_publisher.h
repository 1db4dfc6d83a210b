#pragma once
// The TF side of a relocalization, following REP 105.
//  - With an odom frame, the relocalizer owns map -> odom: it is computed from
//    the relocalized camera pose and odom -> camera at the frame's stamp, so the
//    odometry chain below stays continuous while the map correction jumps. It
//    is post-dated by transform_tolerance (as amcl does), otherwise every TF
//    consumer would have to extrapolate past the last correction, and it is
//    re-broadcast at tf_rate because a localizer may answer rarely (on demand).
//  - Without an odom frame, map -> camera is a measurement at the frame's stamp
//    and is sent once, not post-dated: re-sending it later would claim the
//    camera has not moved.

#include <geometry_msgs/TransformStamped.h>
#include <ros/node_handle.h>
#include <ros/timer.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>

#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"

namespace relocalizer_ros {

class TransformPublisher {
 public:
  struct Options {
    std::string odom_frame;  // empty: map -> camera
    double transform_tolerance = 0.1;
    double tf_rate = 10.0;
    double tf_timeout = 0.2;
  };

  // `tf`: the node's buffer (relocalizer_node.h), read in odom mode only; it outlives this.
  TransformPublisher(ros::NodeHandle nh, Options options, tf2_ros::Buffer& tf);

  // The transform that publishes `map_T_camera` (the camera in `map_frame`,
  // the answering place's frame) for a frame of `camera_frame` at `stamp`. In odom mode this waits
  // up to tf_timeout for odom -> camera; a missing transform is an error, never an indefinite wait.
  // Thread-safe. If the lookup fails because the buffer only holds odom -> camera from more than
  // its cache length after `stamp` (the source's time went back, e.g. a looping bag, and an
  // old-timeline transform arrived after reset()), tf2 would refuse every new transform as too old
  // until time caught up again; the buffer is cleared instead and the error says so.
  relocalizer::Expected<geometry_msgs::TransformStamped> prepare(
      const relocalizer::Pose& map_T_camera, const std::string& map_frame, const ros::Time& stamp,
      const std::string& camera_frame) const;

  // Broadcasts a prepared transform and, in odom mode, keeps it for the
  // re-broadcast unless one from a later frame is already kept: the worker and
  // service calls may finish out of order, and an older correction is still
  // right at its own stamp but must not replace a newer one. `epoch` counts
  // the input's time jumps: a frame from after a jump replaces whatever was
  // kept, however its stamp compares, and one from before it never does.
  void send(const geometry_msgs::TransformStamped& transform, const ros::Time& frame_stamp,
            uint64_t epoch = 0);

  // The input's time went backwards: forget odom -> camera (the tf2 buffer
  // would reject the new timeline's transforms as older than its newest
  // ones). The kept map -> odom is still re-broadcast until a frame of the
  // new timeline replaces it.
  void reset();

 private:
  void rebroadcast(const ros::WallTimerEvent&);
  // prepare()'s recovery from a buffer that holds only a later timeline:
  // clears it and returns the note for the error, or returns "".
  std::string clearIfOnlyFuture(const ros::Time& stamp, const std::string& camera_frame) const;

  const Options options_;
  tf2_ros::TransformBroadcaster broadcaster_;
  tf2_ros::Buffer& buffer_;
  ros::WallTimer timer_;

  std::mutex mutex_;
  std::optional<geometry_msgs::TransformStamped> map_to_odom_;
  ros::Time map_to_odom_source_stamp_;
  uint64_t map_to_odom_epoch_ = 0;
};

}  // namespace relocalizer_ros
