#include "node_hints.h"

#include <tf2/exceptions.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "../conversion/message_conversion.h"
#include "node_text.h"
#include "relocalizer/core/outside_text.h"

namespace relocalizer_ros {

namespace {

using relocalizer::Matrix6d;
using relocalizer::PoseHint;

// A free axis (variance 0) gets this variance while the covariance is rotated
// into the map frame, and an axis that ends with at least half of it is free
// again: a yaw-only transform keeps z, roll and pitch free, a tilted one makes
// free what it mixes them into.
constexpr double kFreeVariance = 1e6;
// |q| further than this from 1 is no orientation.
constexpr double kQuaternionTolerance = 0.01;

std::string withoutSlash(std::string frame) {
  if (!frame.empty() && frame.front() == '/') frame.erase(0, 1);
  return frame;
}

Matrix6d rotateCovariance(Matrix6d c, const Eigen::Matrix3d& rotation) {
  for (int i = 0; i < 6; ++i)
    if (c(i, i) == 0) c(i, i) = kFreeVariance;
  Matrix6d r = Matrix6d::Zero();
  r.topLeftCorner<3, 3>() = rotation;
  r.bottomRightCorner<3, 3>() = rotation;
  c = r * c * r.transpose();
  for (int i = 0; i < 6; ++i)
    if (c(i, i) >= 0.5 * kFreeVariance) {
      c.row(i).setZero();
      c.col(i).setZero();
    }
  return c;
}

// With roll and pitch free the hint is a pose on the floor plane, an arrow
// (RViz's 2D Pose Estimate), not a camera: it becomes a level camera looking
// along the arrow (optical z along its x axis), so that the rotation error
// about the map's z axis is the heading error.
Eigen::Matrix3d levelCameraAlong(const Eigen::Matrix3d& arrow) {
  const double yaw = std::atan2(arrow(1, 0), arrow(0, 0));
  Eigen::Matrix3d optical;  // optical axes in a body frame with x forward, z up
  optical.col(0) = -Eigen::Vector3d::UnitY();
  optical.col(1) = -Eigen::Vector3d::UnitZ();
  optical.col(2) = Eigen::Vector3d::UnitX();
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * optical;
}

// Beyond this, an entry is no covariance but a unit or overflow mistake
// (1e300 was read as "all zero", issue 38 W4); a free axis is 0.
constexpr double kMaxCovarianceEntry = 1e9;

// What is wrong with the message's covariance as given (before it is rotated
// into a map frame, which would turn a huge entry into a free axis or into
// infinity); empty when nothing is.
std::string messageCovarianceError(const Matrix6d& c) {
  static const char* const kAxes[6] = {"x", "y", "z", "roll", "pitch", "yaw"};
  char buffer[200];
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      const char* what = !std::isfinite(c(i, j))                   ? "is not finite"
                         : std::abs(c(i, j)) > kMaxCovarianceEntry ? "is too large"
                         : i == j && c(i, i) < 0                   ? "is negative"
                                                                   : nullptr;
      if (!what) continue;
      std::snprintf(buffer, sizeof buffer,
                    "the hint's covariance %s: %g at %s, %s (entries must be finite, at most %g "
                    "in size, variances >= 0; 0 leaves an axis free)",
                    what, c(i, j), kAxes[i], kAxes[j], kMaxCovarianceEntry);
      return buffer;
    }
  return {};
}

std::string joined(const std::vector<std::string>& frames) {
  std::string text;
  for (const std::string& f : frames) text += (text.empty() ? "" : ", ") + f;
  return text;
}

}  // namespace

NodeHints::NodeHints(ros::NodeHandle nh, const HintSettings& params, tf2_ros::Buffer& tf,
                     std::function<std::vector<std::string>()> map_frames)
    : params_(params), map_frames_(std::move(map_frames)), buffer_(tf) {
  subscriber_ = nh.subscribe("initialpose", 1, &NodeHints::onMessage, this);
}

relocalizer::Expected<PoseHint> NodeHints::read(const HintMsg& msg) const {
  const std::string source = withoutSlash(msg.header.frame_id);
  if (source.empty())
    return relocalizer::makeError("the hint has no header.frame_id (the frame its pose is in)");
  if (std::string why = relocalizer::nameError(source, "the hint's header.frame_id"); !why.empty())
    return relocalizer::makeError(why);
  const geometry_msgs::Pose& p = msg.pose.pose;
  const Eigen::Vector4d q(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w);
  if (!std::isfinite(p.position.x) || !std::isfinite(p.position.y) ||
      !std::isfinite(p.position.z) || !q.allFinite())
    return relocalizer::makeError("the hint's pose is not finite");
  if (std::abs(q.norm() - 1.0) > kQuaternionTolerance) {
    char buffer[160];
    std::snprintf(buffer, sizeof buffer,
                  "the hint's orientation is not a unit quaternion (|q| = %g; for no turn give "
                  "x y z w = 0 0 0 1)",
                  q.norm());
    return relocalizer::makeError(buffer);
  }

  std::vector<std::string> frames = map_frames_();
  for (std::string& f : frames) f = withoutSlash(f);
  Pose map_from_source = Pose::Identity();
  std::string target;
  if (std::find(frames.begin(), frames.end(), source) != frames.end()) {
    target = source;
  } else {
    std::string why;
    for (const std::string& frame : frames) {
      try {
        // The latest transform: a hint says where the camera is now.
        map_from_source =
            fromTransformMsg(buffer_.lookupTransform(frame, source, ros::Time(0)).transform);
        target = frame;
        break;
      } catch (const tf2::TransformException& e) {
        why = messageExcerpt(e.what(), 256);
      }
    }
    if (target.empty())
      return relocalizer::makeError("frame '" + source + "' is no place's map frame (" +
                                    joined(frames) + ") and TF brings it into none of them" +
                                    (why.empty() ? "" : ": " + why));
  }
  const Matrix6d covariance = covarianceFromMsg(msg.pose);
  if (std::string why = messageCovarianceError(covariance); !why.empty())
    return relocalizer::makeError(why);
  PoseHint hint;
  hint.frame = target;
  hint.pose = map_from_source * fromPoseMsg(p);
  hint.covariance = rotateCovariance(covariance, map_from_source.linear());
  if (covariance.diagonal().any() && !hint.covariance.diagonal().any())
    return relocalizer::makeError(
        "the hint's covariance constrains nothing: every variance is 0 (free) or at least " +
        std::to_string(static_cast<long>(0.5 * kFreeVariance)) +
        " (as good as free); give variances for x, y and yaw below that");
  if (hint.covariance(3, 3) == 0 && hint.covariance(4, 4) == 0)
    hint.pose.linear() = levelCameraAlong(hint.pose.linear());
  if (std::string why = relocalizer::poseHintError(hint); !why.empty())
    return relocalizer::makeError(why);
  return hint;
}

void NodeHints::onMessage(const ros::MessageEvent<const HintMsg>& event) {
  const std::string from = event.getPublisherName();
  // Our own accepted poses, forwarded on /initialpose for amcl: taking them
  // back would make every answer its own next hint.
  if (from == ros::this_node::getName()) {
    ++own_ignored_;
    return;
  }
  const relocalizer::Expected<PoseHint> hint = read(*event.getConstMessage());
  if (!hint) {
    if (log_.allow(hint.error()))
      ROS_WARN("relocalizer: pose hint on %s from %s refused: %s", topic().c_str(), from.c_str(),
               hint.error().c_str());
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  pending_ = Pending{*hint, Clock::now(), next_id_++};
  const Eigen::Vector3d t = hint->pose.translation();
  ROS_INFO(
      "relocalizer: pose hint on %s from %s in %s at (%.2f, %.2f, %.2f): it holds for %s s or "
      "until an answer with a pose",
      topic().c_str(), from.c_str(), hint->frame.c_str(), t.x(), t.y(), t.z(),
      secondsText(params_.hint_timeout).c_str());
}

std::optional<NodeHints::Pending> NodeHints::current() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (pending_ && std::chrono::duration<double>(Clock::now() - pending_->arrival).count() >
                      params_.hint_timeout) {
    ROS_INFO("relocalizer: the pose hint expired unused (hint_timeout %s s)",
             secondsText(params_.hint_timeout).c_str());
    pending_.reset();
  }
  return pending_;
}

bool NodeHints::pending() const { return current().has_value(); }

relocalizer::PlaceAnswer NodeHints::relocalize(const Relocalize& relocalize,
                                               const PoseHint* requested) const {
  if (requested) return relocalize(requested);
  const std::optional<Pending> hint = current();
  relocalizer::PlaceAnswer answer = relocalize(hint ? &hint->hint : nullptr);
  if (hint && answer.relocalization.success) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (pending_ && pending_->id == hint->id) pending_.reset();
    ROS_INFO("relocalizer: answered in %s with the pose hint, which is now spent",
             answer.map_frame.c_str());
  }
  return answer;
}

}  // namespace relocalizer_ros
