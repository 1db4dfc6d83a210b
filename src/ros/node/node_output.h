#pragma once
// The node's output side: ~result for every attempt and report, and for an
// answer that holds, ~pose and TF (transform_publisher.h). An answer is
// published whole or not at all: a pose whose TF cannot be prepared is a
// failure with that reason, never a pose without its correction.

#include <relocalizer/RelocalizationResult.h>
#include <ros/ros.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "frame_input.h"
#include "relocalizer/relocalize/place_set.h"
#include "tf_settings.h"
#include "throttled_log.h"
#include "transform_publisher.h"

namespace relocalizer_ros {

// The time an answer holds for, its stamp everywhere (~result, ~pose, TF, the
// service): the depth image's for a pose; an answer without one carries the
// colour image's, as every report of a frame does.
ros::Time answerStamp(const FrameInput& input, const relocalizer::Relocalization& solved);

class NodeOutput {
 public:
  using ResultMsg = relocalizer::RelocalizationResult;
  using Clock = std::chrono::steady_clock;

  // What a listener sees of each ~result once it is published: the parts that
  // watch answers (diagnostics, RViz, hand-off) see exactly what users see.
  struct Published {
    const ResultMsg& result;
    const FrameInput* input = nullptr;                // null for a report that is no frame's
    const relocalizer::PlaceAnswer* found = nullptr;  // null when the frame was not relocalized
  };
  using Listener = std::function<void(const Published&)>;

  // `learned_place`: the learned place's name (placeName(), place_settings.h),
  // "" outside learn mode. `counters` fills the node's counters into every
  // ~result; `tf`, the node's buffer, is lent to the TransformPublisher and
  // outlives this.
  NodeOutput(ros::NodeHandle nh, ros::NodeHandle private_nh, const TfSettings& settings,
             std::string learned_place, std::function<void(ResultMsg&)> counters,
             tf2_ros::Buffer& tf);

  ResultMsg failure(const ros::Time& stamp, const std::string& message) const;

  // A relocalized frame's answer: ~result, and when the pose holds and its TF
  // could be prepared, ~pose and TF, in the answering place's map frame. Logs
  // a failure (throttled per reason) and each change of the answering place.
  ResultMsg answer(const FrameInput& input, const relocalizer::PlaceAnswer& found,
                   Clock::time_point start);
  // A frame that was not relocalized (unusable, no model yet, an internal error).
  void frameFailed(ResultMsg& result, const FrameInput* input = nullptr);
  // A report that is no frame's answer (no frame for a call, a time jump, the watchdog).
  void report(ResultMsg& result);

  // Called on the publishing thread after every ~result. Add listeners before
  // any frame or service call can arrive: the list is not locked.
  void addListener(Listener listener) { listeners_.push_back(std::move(listener)); }

  // The input's time went back: tf2 would refuse the new timeline's odometry.
  void resetTransforms();
  uint64_t framesFailed() const { return frames_failed_; }

 private:
  // Says so when the answering place is another than the last answer's.
  void logPlace(const ros::Time& stamp, const relocalizer::PlaceAnswer& found);
  void publish(ResultMsg& result, const std::optional<geometry_msgs::TransformStamped>& transform,
               uint64_t epoch, const FrameInput* input = nullptr,
               const relocalizer::PlaceAnswer* found = nullptr);

  const TfSettings& settings_;
  const std::string learned_place_;
  const std::function<void(ResultMsg&)> counters_;
  ros::Publisher pose_pub_;
  ros::Publisher result_pub_;
  std::unique_ptr<TransformPublisher> transforms_;
  std::atomic<uint64_t> frames_failed_{0};
  ThrottledLog log_;
  std::mutex place_mutex_;
  std::string last_place_;  // the place (or learned group) of the last answer, for the log
  std::vector<Listener> listeners_;
};

}  // namespace relocalizer_ros
