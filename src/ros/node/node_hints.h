#pragma once
// Pose hints for the node: `initialpose` (geometry_msgs/PoseWithCovarianceStamped,
// as RViz's "2D Pose Estimate" and amcl use it) and the optional hint of a
// ~relocalize call, brought by TF into a place's map frame and handed to the
// core as relocalizer::PoseHint (pose/pose_hint.h), which favours hypotheses
// near it. A topic hint holds for hint_timeout seconds, until an answer with
// a pose used it. Messages this node published itself (its accepted poses
// forwarded on /initialpose) are never taken back as hints.

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "hint_settings.h"
#include "relocalizer/pose/pose_hint.h"
#include "relocalizer/relocalize/place_set.h"
#include "throttled_log.h"

namespace relocalizer_ros {

class NodeHints {
 public:
  using HintMsg = geometry_msgs::PoseWithCovarianceStamped;
  using Relocalize = std::function<relocalizer::PlaceAnswer(const relocalizer::PoseHint*)>;

  // `map_frames`: the frames a hint may be brought into, in order of
  // preference; `tf`: the node's buffer (relocalizer_node.h), which outlives this.
  NodeHints(ros::NodeHandle nh, const HintSettings& params, tf2_ros::Buffer& tf,
            std::function<std::vector<std::string>()> map_frames);

  // A message as a hint in one of the map frames (its own frame when it is
  // one, else the first TF reaches from it), or why it cannot be one.
  relocalizer::Expected<relocalizer::PoseHint> read(const HintMsg& msg) const;

  // Runs `relocalize` with `requested` (a call's own hint), or else with the
  // current topic hint, which an answer with a pose spends.
  relocalizer::PlaceAnswer relocalize(const Relocalize& relocalize,
                                      const relocalizer::PoseHint* requested) const;

  std::string topic() const { return subscriber_.getTopic(); }
  // Messages from this node itself that were ignored.
  uint64_t ownMessagesIgnored() const { return own_ignored_; }
  // Whether a topic hint is waiting for the next relocalization.
  bool pending() const;

 private:
  using Clock = std::chrono::steady_clock;
  struct Pending {
    relocalizer::PoseHint hint;
    Clock::time_point arrival;
    uint64_t id = 0;
  };

  void onMessage(const ros::MessageEvent<const HintMsg>& event);
  std::optional<Pending> current() const;

  const HintSettings& params_;
  const std::function<std::vector<std::string>()> map_frames_;
  tf2_ros::Buffer& buffer_;
  ros::Subscriber subscriber_;
  mutable std::mutex mutex_;
  mutable std::optional<Pending> pending_;
  uint64_t next_id_ = 1;
  std::atomic<uint64_t> own_ignored_{0};
  mutable ThrottledLog log_;
};

}  // namespace relocalizer_ros
