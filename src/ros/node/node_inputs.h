#pragma once
// The node's input side: colour, depth and camera_info subscriptions, their
// stamp checks and synchronisation (input_synchronizer.h), per-topic counts,
// time-jump reports and the watchdog that notices inputs that stop or never
// form a set. Hands each synchronised set on and never waits for a consumer.
//
// Threads: subscription callbacks (the node handle's queue) feed the
// synchronizer under one mutex; the watchdog is a wall timer on the same queue.

#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <ros/ros.h>

#include <array>
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "frame_input.h"
#include "input_settings.h"
#include "input_synchronizer.h"
#include "tf_settings.h"
#include "throttled_log.h"

namespace relocalizer_ros {

class NodeInputs {
 public:
  struct Handlers {
    std::function<void(FrameInputPtr)> on_frame;  // every synchronised set, usable or not
    // The stamps moved to another timeline: drop what waits from the old one;
    // returns the number of frames dropped.
    std::function<size_t()> on_jump;
    // Continuous mode: a report for ~result (a jump, or inputs that never sync).
    std::function<void(const ros::Time& stamp, const std::string& what)> on_report;
  };

  // Subscribes at once (relative names rgb/image, depth/image, rgb/camera_info).
  NodeInputs(ros::NodeHandle nh, ros::NodeHandle private_nh, const InputSettings& params,
             const TfSettings& tf_settings, Handlers handlers);
  ~NodeInputs();
  NodeInputs(const NodeInputs&) = delete;
  NodeInputs& operator=(const NodeInputs&) = delete;

  // No input callback runs after this returns (roscpp waits for one in progress).
  void stop();

  // Per-topic message counts since the last synchronised set and what they
  // suggest, for "no frame" messages.
  std::string status() const;
  std::string topics() const;  // "A, B, C" for the start-up line

  uint64_t framesReceived() const { return frames_received_; }
  uint64_t timeJumps() const { return time_jumps_; }
  uint64_t messagesDropped() const { return messages_dropped_; }

  // What /diagnostics shows of the inputs (node_diagnostics.h).
  struct Activity {
    std::array<std::string, 3> topics;   // colour, depth, camera_info, as resolved
    std::array<uint64_t, 3> messages{};  // received on each since start
    bool any_frame = false;              // a synchronised set arrived
    double since_frame = 0.0;            // seconds since the last set, or since start when none
  };
  Activity activity() const;

 private:
  template <int I, typename M>
  void onInput(const boost::shared_ptr<M const>& message);
  void onSynchronised(const sensor_msgs::ImageConstPtr& colour,
                      const sensor_msgs::ImageConstPtr& depth,
                      const sensor_msgs::CameraInfoConstPtr& info);
  // Called with input_mutex_ held, before the new timeline's first message is synchronised.
  void onTimeJump(const StampGate::Jump& jump);
  void onStampDropped(int input, StampGate::Drop why, int64_t stamp_ns);
  void onWatchdog(const ros::WallTimerEvent&);
  std::string topic(int input) const;
  // Seconds from the steady-clock time `last_ns` (0: never, then from the start) to `now_ns`.
  double secondsSince(int64_t last_ns, int64_t now_ns) const;

  ros::NodeHandle nh_;
  const InputSettings& params_;
  const TfSettings& tf_settings_;
  const Handlers handlers_;
  ThrottledLog log_;

  std::atomic<uint64_t> frames_received_{0};
  std::atomic<uint64_t> time_jumps_{0};        // also the epoch of new inputs
  std::atomic<uint64_t> messages_dropped_{0};  // refused for their stamps
  std::atomic<uint64_t> colour_count_{0}, depth_count_{0}, info_count_{0};
  // The counts at the last synchronised set: what arrived since says which
  // input is missing now, whatever worked before.
  std::atomic<uint64_t> colour_at_sync_{0}, depth_at_sync_{0}, info_at_sync_{0};
  std::atomic<int64_t> last_image_ns_{0};  // steady clock of the last colour or depth image
  std::atomic<int64_t> last_frame_ns_{0};  // steady clock of the last synchronised set
  const int64_t start_ns_;
  ros::Time last_image_stamp_;  // for the watchdog's reports; guarded by stamp_mutex_
  mutable std::mutex stamp_mutex_;

  // The synchronizer and its jump reports; guarded by input_mutex_. A jump is
  // seen on each input in turn (separate connections): one jump is one reset
  // and one report.
  std::mutex input_mutex_;
  std::unique_ptr<InputSynchronizer> inputs_;
  std::chrono::steady_clock::time_point last_jump_log_;
  uint64_t unlogged_jumps_ = 0;

  ros::WallTimer watchdog_;
  // Last: destroyed first, so no callback outlives what it uses.
  std::unique_ptr<image_transport::ImageTransport> image_transport_;
  image_transport::SubscriberFilter colour_sub_;
  image_transport::SubscriberFilter depth_sub_;
  message_filters::Subscriber<sensor_msgs::CameraInfo> info_sub_;
};

}  // namespace relocalizer_ros
