#pragma once
// The ROS face of the relocalizer: synchronised RGB-D in; ~pose, ~result, TF and
// the ~relocalize service out. It translates between ROS and the core facade
// and owns the threading; every decision about poses stays in the core.
//
// Threads:
//  - subscription callbacks (the node handle's queue): O(1) header checks and a
//    hand-over to the FrameBuffer; they never wait for a relocalization. They
//    feed the InputSynchronizer (stamp checks, then message_filters) under
//    one mutex;
//  - the continuous worker (continuous mode): takes the pending frame, at most
//    max_rate times a second, and relocalizes it;
//  - the service calls' own threads (ServiceCallQueue: one per waiting call):
//    calls wait for a frame and relocalize it there, so a waiting call never
//    stalls the image callbacks or another call. Calls that pick
//    the same frame share one relocalization (the core is deterministic per
//    frame), so concurrent calls get the same, well-defined answer cheaply.
//  - the watchdog and TF re-broadcast wall timers (the node handle's queue);
//  - learn mode: the learning thread takes the newest frame, looks up the
//    SLAM pose map_frame -> camera at its stamp, keeps key frames and hands
//    them to the learner, whose own low-priority worker retrains the model
//    (online_learner.h). Relocalizations use whichever model is current.

#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <relocalizer/Relocalize.h>
#include <relocalizer/SaveModel.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tbb/global_control.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "frame_buffer.h"
#include "input_synchronizer.h"
#include "key_frames.h"
#include "node_params.h"
#include "service_call_queue.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/pose/relocalizer.h"
#include <relocalizer/RelocalizationResult.h>
#include "throttled_log.h"
#include "transform_publisher.h"

namespace relocalizer_ros {

class RelocalizerNode {
 public:
  // Reads the parameters and loads the model; fails with one line naming the
  // parameter or file at fault. Subscribes only once the model is ready, so a
  // publisher that waits for a subscriber (the replay player) waits for it.
  static relocalizer::Expected<std::unique_ptr<RelocalizerNode>> create(ros::NodeHandle nh,
                                                                       ros::NodeHandle private_nh);
  ~RelocalizerNode();
  RelocalizerNode(const RelocalizerNode&) = delete;
  RelocalizerNode& operator=(const RelocalizerNode&) = delete;

 private:
  // One synchronised set as received. Holding the messages (not pixels) keeps
  // the callbacks O(1) and converts only frames that are actually used.
  struct Input {
    sensor_msgs::ImageConstPtr colour;
    sensor_msgs::ImageConstPtr depth;
    sensor_msgs::CameraInfoConstPtr info;
    std::string error;  // why the set cannot be a frame (checked on arrival)
    uint64_t epoch = 0;  // time jumps seen before it was synchronised
  };
  using InputPtr = std::shared_ptr<const Input>;
  using ResultMsg = relocalizer::RelocalizationResult;

  RelocalizerNode(ros::NodeHandle nh, ros::NodeHandle private_nh, NodeParams params,
                  std::shared_ptr<const relocalizer::Relocalizer> relocalizer,
                  std::unique_ptr<relocalizer::OnlineLearner> learner);

  // The model relocalizations use now: the loaded one, or the learner's newest
  // (null while learning has produced none yet).
  std::shared_ptr<const relocalizer::Relocalizer> currentModel() const;
  void learnLoop();
  bool onSaveModel(relocalizer::SaveModel::Request& request, relocalizer::SaveModel::Response& response);

  void subscribe();
  // Every input message passes here: stamp checks, then the synchronizer.
  template <int I, typename M>
  void onInput(const boost::shared_ptr<M const>& message);
  // The input stamps moved to another timeline (called with input_mutex_ held,
  // before the new timeline's first message is synchronised).
  void onTimeJump(const StampGate::Jump& jump);
  void onStampDropped(int input, StampGate::Drop why, int64_t stamp_ns);
  std::string inputTopic(int input) const;
  void onSynchronised(const sensor_msgs::ImageConstPtr& colour,
                      const sensor_msgs::ImageConstPtr& depth,
                      const sensor_msgs::CameraInfoConstPtr& info);
  void onWatchdog(const ros::WallTimerEvent&);
  bool onRelocalize(relocalizer::Relocalize::Request& request,
                    relocalizer::Relocalize::Response& response);
  void workerLoop();

  // Relocalizes one input and publishes ~result, and on success ~pose and TF.
  ResultMsg process(const Input& input);
  ResultMsg processChecked(const Input& input, std::chrono::steady_clock::time_point start);
  // A service call's relocalization of buffer entry `seq`, shared with any
  // concurrent call that picked the same entry.
  ResultMsg processShared(uint64_t seq, const InputPtr& input);
  ResultMsg failure(const ros::Time& stamp, const std::string& message) const;
  // `frame_attempt`: the result is a processed frame's (counted in
  // frames_failed when it failed), not a report such as "no frame".
  void publishOutcome(ResultMsg& result, const relocalizer::Pose* pose,
                      const relocalizer::Matrix6d* covariance,
                      const std::optional<geometry_msgs::TransformStamped>& transform,
                      bool frame_attempt, uint64_t epoch = 0);
  // Per-topic message counts and what they suggest, for "no frame" messages.
  std::string inputStatus() const;

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  const NodeParams params_;
  std::unique_ptr<tbb::global_control> thread_limit_;
  const std::shared_ptr<const relocalizer::Relocalizer> fixed_model_;  // null in learn mode
  // Learn mode: the learner, the frames waiting for the learning thread (the
  // newest only: key frames are chosen by motion, so a skipped frame is
  // covered by the next), SLAM's TF and the key-frame rule.
  const std::unique_ptr<relocalizer::OnlineLearner> learner_;
  FrameBuffer<InputPtr> learn_frames_{FrameBuffer<InputPtr>::Policy::Latest};
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<KeyFrameSelector> key_frames_;
  std::thread learn_worker_;
  std::atomic<uint64_t> frames_untracked_{0};  // learn mode: frames without the SLAM pose

  ros::Publisher pose_pub_;
  ros::Publisher result_pub_;
  std::unique_ptr<TransformPublisher> transforms_;
  FrameBuffer<InputPtr> frames_;
  ThrottledLog log_;

  std::atomic<uint64_t> frames_received_{0};
  std::atomic<uint64_t> frames_processed_{0};
  std::atomic<uint64_t> frames_failed_{0};
  std::atomic<uint64_t> time_jumps_{0};  // also the epoch of new inputs
  std::atomic<uint64_t> messages_dropped_{0};  // input messages refused for their stamps
  std::atomic<uint64_t> colour_count_{0}, depth_count_{0}, info_count_{0};
  // The counts at the last synchronised set: what arrived since says which
  // input is missing now, whatever worked before.
  std::atomic<uint64_t> colour_at_sync_{0}, depth_at_sync_{0}, info_at_sync_{0};
  std::atomic<int64_t> last_image_ns_{0};  // steady clock of the last colour or depth image
  std::atomic<int64_t> last_frame_ns_{0};  // steady clock of the last synchronised set
  const int64_t start_ns_;
  ros::Time last_image_stamp_;  // for watchdog failure results; guarded by stamp_mutex_
  mutable std::mutex stamp_mutex_;

  std::mutex shared_mutex_;
  std::map<uint64_t, std::shared_future<ResultMsg>> in_flight_;

  std::thread worker_;

  // The inputs' synchronizer and what its jumps report; guarded by input_mutex_.
  // A jump is seen on each input in turn (they are separate connections):
  // one jump is one reset and one report.
  std::mutex input_mutex_;
  std::unique_ptr<InputSynchronizer> inputs_;
  std::chrono::steady_clock::time_point last_jump_log_;
  uint64_t unlogged_jumps_ = 0;

  // Service calls: a thread each, so none waits behind another; saves one at a time.
  ServiceCallQueue service_calls_;
  std::mutex save_mutex_;
  ros::ServiceServer service_;
  ros::ServiceServer save_service_;
  ros::WallTimer watchdog_;

  // Last members: destroyed first, so no callback outlives what it uses (the
  // subscribers' callbacks feed the synchronizer).
  std::unique_ptr<image_transport::ImageTransport> image_transport_;
  image_transport::SubscriberFilter colour_sub_;
  image_transport::SubscriberFilter depth_sub_;
  message_filters::Subscriber<sensor_msgs::CameraInfo> info_sub_;
};

}  // namespace relocalizer_ros
