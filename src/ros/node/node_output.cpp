#include "node_output.h"

#include <algorithm>

#include "../conversion/message_conversion.h"
#include "node_text.h"
#include "place_settings.h"

namespace relocalizer_ros {

ros::Time answerStamp(const FrameInput& input, const relocalizer::Relocalization& solved) {
  // With or without depth ICP: the solver's points are the depth's too
  // (test_stamps.cpp measures both).
  return solved.success ? geometryStamp(input) : input.colour->header.stamp;
}

NodeOutput::NodeOutput(ros::NodeHandle nh, ros::NodeHandle private_nh, const TfSettings& settings,
                       std::string learned_place, std::function<void(ResultMsg&)> counters,
                       tf2_ros::Buffer& tf)
    : settings_(settings),
      learned_place_(std::move(learned_place)),
      counters_(std::move(counters)) {
  pose_pub_ = private_nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 1, true);
  result_pub_ = private_nh.advertise<ResultMsg>("result", 10);
  if (settings_.publish_tf) {
    TransformPublisher::Options options;
    options.odom_frame = settings_.odom_frame;
    options.transform_tolerance = settings_.transform_tolerance;
    options.tf_rate = settings_.tf_rate;
    options.tf_timeout = settings_.tf_timeout;
    transforms_ = std::make_unique<TransformPublisher>(nh, options, tf);
  }
}

NodeOutput::ResultMsg NodeOutput::failure(const ros::Time& stamp,
                                          const std::string& message) const {
  ResultMsg result;
  result.header.stamp = stamp;
  result.header.frame_id = settings_.map_frame;
  result.success = false;
  result.message = message;
  result.surface_agreement = -1.0f;  // not checked
  return result;
}

NodeOutput::ResultMsg NodeOutput::answer(const FrameInput& input,
                                         const relocalizer::PlaceAnswer& found,
                                         Clock::time_point start) {
  const relocalizer::Relocalization& solved = found.relocalization;
  const ros::Time stamp = answerStamp(input, solved);
  ResultMsg result = failure(stamp, "");
  result.places_screened = saturate(found.attempts.size());
  result.places_solved = saturate(static_cast<uint64_t>(
      std::count_if(found.attempts.begin(), found.attempts.end(),
                    [](const relocalizer::PlaceAttempt& attempt) { return attempt.solved; })));
  if (solved.success) {
    result.place = found.place;
    result.header.frame_id = found.map_frame;
  }
  result.success = solved.success;
  result.message = solved.message;
  result.point_inliers = static_cast<uint32_t>(solved.point_inliers);
  result.line_inliers = static_cast<uint32_t>(solved.line_inliers);
  result.score = solved.score;
  result.surface_agreement = solved.surface_agreement;
  result.light_cast = solved.light_cast;
  result.time_sampling = static_cast<float>(solved.timings.sampling);
  result.time_forest = static_cast<float>(solved.timings.forest);
  result.time_ransac = static_cast<float>(solved.timings.ransac);
  result.time_refinement = static_cast<float>(solved.timings.refinement);
  result.time_surface = static_cast<float>(solved.timings.surface);

  std::optional<geometry_msgs::TransformStamped> transform;
  if (solved.success && transforms_) {
    const std::string camera_frame = stripLeadingSlashes(input.colour->header.frame_id);
    auto prepared = transforms_->prepare(solved.pose, found.map_frame, stamp, camera_frame);
    if (prepared) {
      transform = std::move(*prepared);
    } else {
      // The pose alone would leave TF consumers without the correction they
      // act on; report the attempt as failed rather than half-done.
      result.success = false;
      result.header.stamp = input.colour->header.stamp;  // as every answer without a pose
      result.message = "relocalized in place '" + found.place + "', but " + prepared.error();
    }
  }
  if (!result.success && log_.allow(result.message)) {
    if (solved.success)  // TF trouble is a configuration fault, not a hard frame
      ROS_WARN("relocalizer: frame at %.3f: %s", stamp.toSec(), result.message.c_str());
    else
      ROS_INFO("relocalizer: no pose for the frame at %.3f: %s", stamp.toSec(),
               result.message.c_str());
  }
  if (result.success) {
    logPlace(stamp, found);
    result.pose.header = result.header;
    result.pose.pose = toPoseWithCovarianceMsg(solved.pose, solved.covariance);
  } else {
    ++frames_failed_;
  }
  result.processing_time = std::chrono::duration<float>(Clock::now() - start).count();
  publish(result, transform, input.epoch, &input, &found);
  return result;
}

void NodeOutput::logPlace(const ros::Time& stamp, const relocalizer::PlaceAnswer& found) {
  // The learned submaps are one map: answers that move between them as the
  // camera walks are not news.
  const std::string place =
      isLearnedPlaceName(learned_place_, found.place) ? learned_place_ : found.place;
  {
    std::lock_guard<std::mutex> lock(place_mutex_);
    if (place == last_place_) return;
    last_place_ = place;
  }
  ROS_INFO("relocalizer: the frame at %.3f is in place '%s' (%s; %zu places screened)",
           stamp.toSec(), found.place.c_str(), found.map_frame.c_str(), found.attempts.size());
}

void NodeOutput::frameFailed(ResultMsg& result, const FrameInput* input) {
  ++frames_failed_;
  publish(result, std::nullopt, 0, input);
}

void NodeOutput::report(ResultMsg& result) { publish(result, std::nullopt, 0); }

void NodeOutput::resetTransforms() {
  if (transforms_) transforms_->reset();
}

void NodeOutput::publish(ResultMsg& result,
                         const std::optional<geometry_msgs::TransformStamped>& transform,
                         uint64_t epoch, const FrameInput* input,
                         const relocalizer::PlaceAnswer* found) {
  counters_(result);
  result_pub_.publish(result);
  if (result.success) {
    pose_pub_.publish(result.pose);
    if (transform) transforms_->send(*transform, result.header.stamp, epoch);
  }
  const Published published{result, input, found};
  for (const Listener& listener : listeners_) listener(published);
}

}  // namespace relocalizer_ros
