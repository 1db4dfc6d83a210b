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
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "relocalizer/expected.h"
#include "relocalizer/pose.h"

namespace relocalizer_ros {

class TransformPublisher {
 public:
  struct Options {
    std::string map_frame = "map";
    std::string odom_frame;  // empty: map -> camera
    double transform_tolerance = 0.1;
    double tf_rate = 10.0;
    double tf_timeout = 0.2;
  };

  TransformPublisher(ros::NodeHandle nh, Options options);

  // The transform that publishes `map_T_camera` for a frame of `camera_frame`
  // at `stamp`. In odom mode this waits up to tf_timeout for odom -> camera;
  // a missing transform is an error, never an indefinite wait. Thread-safe.
  relocalizer::Expected<geometry_msgs::TransformStamped> prepare(const relocalizer::Pose& map_T_camera,
                                                                  const ros::Time& stamp,
                                                                  const std::string& camera_frame) const;

  // Broadcasts a prepared transform and, in odom mode, keeps it for the
  // re-broadcast unless one from a later frame is already kept: the worker and
  // service calls may finish out of order, and an older correction is still
  // right at its own stamp but must not replace a newer one.
  void send(const geometry_msgs::TransformStamped& transform, const ros::Time& frame_stamp);

 private:
  void rebroadcast(const ros::WallTimerEvent&);

  const Options options_;
  tf2_ros::TransformBroadcaster broadcaster_;
  std::unique_ptr<tf2_ros::Buffer> buffer_;  // odom mode only
  std::unique_ptr<tf2_ros::TransformListener> listener_;
  ros::WallTimer timer_;

  std::mutex mutex_;
  std::optional<geometry_msgs::TransformStamped> map_to_odom_;
  ros::Time map_to_odom_source_stamp_;
};

}  // namespace relocalizer_ros
