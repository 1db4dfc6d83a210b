#include "pose_handoff.h"

#include <relocalizer/SetPose.h>

#include <algorithm>

#include "../conversion/message_conversion.h"
#include "node_text.h"

namespace relocalizer_ros {

Matrix6d moveCovariance(const Matrix6d& covariance, const Pose& map_T_camera,
                        const Pose& camera_T_frame) {
  // The solver's covariance is for left perturbations R = Exp(w) R0,
  // t = t0 + v (refinement_costs.h); the frame's origin t0 + R0 c then moves
  // by v + w x (R0 c), and its rotation by the same w.
  const Eigen::Vector3d lever = map_T_camera.linear() * camera_T_frame.translation();
  Matrix6d jacobian = Matrix6d::Identity();
  jacobian.topRightCorner<3, 3>() << 0, lever.z(), -lever.y(), -lever.z(), 0, lever.x(), lever.y(),
      -lever.x(), 0;  // -[lever]x
  return jacobian * covariance * jacobian.transpose();
}

PoseHandoff::PoseHandoff(ros::NodeHandle nh, const HandoffSettings& params, double tf_timeout,
                         tf2_ros::Buffer& tf)
    : params_(params), tf_timeout_(tf_timeout), nh_(std::move(nh)), buffer_(tf) {
  if (params_.forward_initialpose)
    initialpose_pub_ = nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("initialpose", 2);
  if (!params_.handoff_frame.empty()) {
    looker_ = std::thread(&PoseHandoff::lookupLoop, this);
  }
  if (!params_.set_pose_service.empty()) caller_ = std::thread(&PoseHandoff::callLoop, this);
  ROS_INFO("relocalizer: accepted poses (of %s) go to %s%s%s",
           params_.handoff_frame.empty() ? "the camera" : params_.handoff_frame.c_str(),
           params_.forward_initialpose ? initialpose_pub_.getTopic().c_str() : "",
           params_.forward_initialpose && !params_.set_pose_service.empty() ? " and " : "",
           params_.set_pose_service.empty()
               ? ""
               : ("SetPose " + nh_.resolveName(params_.set_pose_service)).c_str());
}

PoseHandoff::~PoseHandoff() {
  {
    // Under the lock, so the lookup thread cannot miss the wake between its
    // check of stopping_ and its wait.
    std::lock_guard<std::mutex> lock(lookup_mutex_);
    stopping_ = true;
  }
  lookup_wake_.notify_all();
  if (looker_.joinable()) looker_.join();
  {
    std::lock_guard<std::mutex> lock(call_mutex_);
    // A persistent client's shutdown drops its connection, which ends a call
    // that waits for a service that does not answer.
    client_.shutdown();
  }
  call_wake_.notify_all();
  if (caller_.joinable()) caller_.join();
}

bool PoseHandoff::claim(uint64_t epoch, const ros::Time& stamp) {
  std::lock_guard<std::mutex> lock(claim_mutex_);
  // A frame from after a time jump is newer whatever its stamp says.
  const bool later =
      !claimed_any_ || epoch > last_epoch_ || (epoch == last_epoch_ && stamp > last_stamp_);
  if (!later) return false;
  claimed_any_ = true;
  last_epoch_ = epoch;
  last_stamp_ = stamp;
  return true;
}

void PoseHandoff::waitForTransform(const std::string& camera_frame, const ros::Time& stamp) const {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(tf_timeout_);
  const ros::Duration slice(std::min(0.1, tf_timeout_));
  while (!stopping_ && !buffer_.canTransform(camera_frame, params_.handoff_frame, stamp, slice) &&
         ros::WallTime::now() < deadline) {
  }
}

relocalizer::Expected<geometry_msgs::PoseWithCovarianceStamped> PoseHandoff::handedPose(
    const Answer& answer) const {
  geometry_msgs::PoseWithCovarianceStamped pose = answer.pose;
  Pose camera_T_frame;
  try {
    waitForTransform(answer.camera_frame, pose.header.stamp);
    camera_T_frame = fromTransformMsg(
        buffer_.lookupTransform(answer.camera_frame, params_.handoff_frame, pose.header.stamp)
            .transform);
  } catch (const tf2::TransformException& e) {
    return relocalizer::makeError("no TF " + messageExcerpt(answer.camera_frame) + " -> " +
                                  messageExcerpt(params_.handoff_frame) +
                                  " at the answer's stamp within " + secondsText(tf_timeout_) +
                                  " s (tf_timeout): " + messageExcerpt(e.what(), 256));
  }
  const Pose map_T_camera = fromPoseMsg(pose.pose.pose);
  const Matrix6d covariance = covarianceFromMsg(pose.pose);
  pose.pose = toPoseWithCovarianceMsg(map_T_camera * camera_T_frame,
                                      moveCovariance(covariance, map_T_camera, camera_T_frame));
  return pose;
}

void PoseHandoff::onPublished(const NodeOutput::Published& published) {
  const NodeOutput::ResultMsg& result = published.result;
  // Only whole answers: a pose whose TF could not be prepared is a failure.
  if (!result.success || !published.input) return;
  if (!claim(published.input->epoch, result.header.stamp)) return;
  if (params_.handoff_frame.empty()) return handOff(result.pose);
  {
    std::lock_guard<std::mutex> lock(lookup_mutex_);
    lookup_pending_ =
        Answer{result.pose, stripLeadingSlashes(published.input->colour->header.frame_id)};
  }
  lookup_wake_.notify_one();
}

void PoseHandoff::lookupLoop() {
  while (true) {
    Answer answer;
    {
      std::unique_lock<std::mutex> lock(lookup_mutex_);
      lookup_wake_.wait(lock, [this] { return stopping_ || lookup_pending_; });
      if (stopping_) return;
      answer = std::move(*lookup_pending_);
      lookup_pending_.reset();
    }
    auto pose = handedPose(answer);
    if (stopping_) return;
    if (pose) {
      handOff(std::move(*pose));
    } else if (log_.allow("handoff frame")) {
      ROS_WARN("relocalizer: the pose at %.3f is not handed off: %s",
               answer.pose.header.stamp.toSec(), pose.error().c_str());
    }
  }
}

void PoseHandoff::handOff(geometry_msgs::PoseWithCovarianceStamped pose) {
  if (initialpose_pub_) initialpose_pub_.publish(pose);
  if (!caller_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(call_mutex_);
    pending_ = std::move(pose);
  }
  call_wake_.notify_one();
}

void PoseHandoff::callLoop() {
  const std::string name = nh_.resolveName(params_.set_pose_service);
  while (true) {
    relocalizer::SetPose call;
    ros::ServiceClient client;
    {
      std::unique_lock<std::mutex> lock(call_mutex_);
      call_wake_.wait(lock, [this] { return stopping_ || pending_; });
      if (stopping_) return;
      call.request.pose = std::move(*pending_);
      pending_.reset();
      // Persistent, so that the destructor can end a call that hangs; a
      // dropped connection (the service restarted) makes a new one.
      if (!client_.isValid()) client_ = nh_.serviceClient<relocalizer::SetPose>(name, true);
      client = client_;
    }
    const double stamp = call.request.pose.header.stamp.toSec();
    if (!client.exists()) {
      if (log_.allow("set_pose absent"))
        ROS_WARN(
            "relocalizer: set_pose_service %s is not advertised; the pose at %.3f is not "
            "handed to it (later poses will be, once it is)",
            name.c_str(), stamp);
      continue;
    }
    if (!client.call(call)) {
      std::lock_guard<std::mutex> lock(call_mutex_);
      if (stopping_) return;
      if (log_.allow("set_pose failed"))
        ROS_WARN(
            "relocalizer: set_pose_service %s failed for the pose at %.3f (is it "
            "robot_localization's SetPose?)",
            name.c_str(), stamp);
      client_.shutdown();
      client_ = ros::ServiceClient();
      continue;
    }
    ROS_DEBUG("relocalizer: handed the pose at %.3f to %s", stamp, name.c_str());
  }
}

}  // namespace relocalizer_ros
