#include "transform_publisher.h"

#include <tf2/exceptions.h>

#include <cstdio>

#include "../conversion/message_conversion.h"

namespace relocalizer_ros {

TransformPublisher::TransformPublisher(ros::NodeHandle nh, Options options, tf2_ros::Buffer& tf)
    : options_(std::move(options)), buffer_(tf) {
  if (options_.odom_frame.empty()) return;
  if (options_.tf_rate > 0.0)
    timer_ = nh.createWallTimer(ros::WallDuration(1.0 / options_.tf_rate),
                                &TransformPublisher::rebroadcast, this);
}

relocalizer::Expected<geometry_msgs::TransformStamped> TransformPublisher::prepare(
    const relocalizer::Pose& map_T_camera, const std::string& map_frame, const ros::Time& stamp,
    const std::string& camera_frame) const {
  geometry_msgs::TransformStamped out;
  out.header.frame_id = map_frame;
  if (options_.odom_frame.empty()) {
    if (camera_frame.empty())
      return relocalizer::makeError(
          "the image has no frame_id, so map -> camera cannot be published");
    out.header.stamp = stamp;
    out.child_frame_id = camera_frame;
    out.transform = toTransformMsg(map_T_camera);
    return out;
  }
  if (camera_frame.empty())
    return relocalizer::makeError("the image has no frame_id, so " + options_.odom_frame +
                                  " -> camera cannot be looked up");
  geometry_msgs::TransformStamped odom_to_camera;
  try {
    odom_to_camera = buffer_.lookupTransform(options_.odom_frame, camera_frame, stamp,
                                             ros::Duration(options_.tf_timeout));
  } catch (const tf2::TransformException& e) {
    char timeout[32];
    std::snprintf(timeout, sizeof(timeout), "%.2f", options_.tf_timeout);
    return relocalizer::makeError(
        "no " + options_.odom_frame + " -> " + messageExcerpt(camera_frame) +
        " transform at the frame stamp within " + timeout + " s: " + messageExcerpt(e.what(), 256) +
        clearIfOnlyFuture(stamp, camera_frame));
  }
  const relocalizer::Pose odom_T_camera = fromTransformMsg(odom_to_camera.transform);
  out.header.stamp = stamp + ros::Duration(options_.transform_tolerance);
  out.child_frame_id = options_.odom_frame;
  out.transform = toTransformMsg(map_T_camera * odom_T_camera.inverse());
  return out;
}

std::string TransformPublisher::clearIfOnlyFuture(const ros::Time& stamp,
                                                  const std::string& camera_frame) const {
  ros::Time latest;
  try {
    latest = buffer_.lookupTransform(options_.odom_frame, camera_frame, ros::Time(0)).header.stamp;
  } catch (const tf2::TransformException&) {
    return {};  // nothing at all: the transform is simply missing
  }
  const ros::Duration ahead = latest - stamp;
  if (ahead <= buffer_.getCacheLength()) return {};
  buffer_.clear();
  char text[160];
  std::snprintf(text, sizeof(text),
                " (TF held %s -> camera only from %.2f s after the frame: time went back; "
                "TF buffer cleared)",
                options_.odom_frame.c_str(), ahead.toSec());
  return text;
}

void TransformPublisher::send(const geometry_msgs::TransformStamped& transform,
                              const ros::Time& frame_stamp, uint64_t epoch) {
  if (!options_.odom_frame.empty()) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!map_to_odom_ || epoch > map_to_odom_epoch_ ||
        (epoch == map_to_odom_epoch_ && frame_stamp >= map_to_odom_source_stamp_)) {
      map_to_odom_ = transform;
      map_to_odom_source_stamp_ = frame_stamp;
      map_to_odom_epoch_ = epoch;
    }
  }
  broadcaster_.sendTransform(transform);
}

void TransformPublisher::reset() {
  if (!options_.odom_frame.empty()) buffer_.clear();
}

void TransformPublisher::rebroadcast(const ros::WallTimerEvent&) {
  geometry_msgs::TransformStamped transform;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!map_to_odom_) return;
    transform = *map_to_odom_;
  }
  // Never older than the post-dated original: consumers already hold that one.
  const ros::Time stamp = ros::Time::now() + ros::Duration(options_.transform_tolerance);
  if (stamp > transform.header.stamp) transform.header.stamp = stamp;
  broadcaster_.sendTransform(transform);
}

}  // namespace relocalizer_ros
