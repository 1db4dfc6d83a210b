#pragma once
// The ROS face of the relocalizer: synchronised RGB-D in; ~pose, ~result, TF and
// the ~relocalize service out. It translates between ROS and the core facade
// and owns the threading; every decision about poses stays in the core. One
// part per concern, composed here:
//  - NodeInputs (node_inputs.h): subscriptions, stamp checks, synchronisation,
//    time jumps, watchdog; hands each set to the FrameBuffer and never waits;
//  - the continuous worker (continuous mode, here): takes the pending frame,
//    at most max_rate times a second, and relocalizes it;
//  - RelocalizeService (relocalize_service.h): calls wait for a frame on
//    their own threads (ServiceCallQueue) and share relocalizations;
//  - LearningFeed (learning_feed.h, learn mode): SLAM-posed key frames into
//    the submap learner, ~save_model; relocalizations use the submaps' models
//    as they are now;
//  - NodePlaces (node_places.h): the places relocalized against, and the
//    services that load, unload and list them;
//  - NodeOutput (node_output.h): ~result, and a whole answer (pose, TF) or none.
//  - NodeDiagnostics (node_diagnostics.h): /diagnostics, from the answers as
//    published, the inputs' activity, the places and the counters.
//  - NodeVisuals (node_visuals.h): ~surface and ~inliers, for RViz.
//  - PoseHandoff (pose_handoff.h, optional): accepted poses to initialpose
//    and robot_localization's SetPose, each frame once.
// Parameters: loadNodeParams (node_params.h) reads them all, each part's by
// its own reader; the node hands each part only the settings it reads
// (*_settings.h), so a part depends on no other's parameters.
// TF: the node owns the one tf2_ros::Buffer and the one listener that fills
// it from /tf and /tf_static (on the listener's own thread, so a lookup that
// waits never waits on the queue that would deliver its transform). It lends
// the buffer by reference to NodeOutput's TransformPublisher (odom -> camera),
// NodeHints (a hint's frame), LearningFeed (SLAM's pose) and PoseHandoff
// (camera -> handoff_frame), each with its own timeout and on its own thread.
// Lifetime rule: the buffer is declared before every borrower, so it is built
// before them and destroyed after them; a borrower keeps the reference only
// while it lives. A clear() by one borrower (a time jump) clears it for all:
// the old timeline's transforms are wrong for every part alike.

#include <ros/ros.h>
#include <tbb/global_control.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <memory>
#include <thread>

#include "frame_buffer.h"
#include "frame_input.h"
#include "learning_feed.h"
#include "node_diagnostics.h"
#include "node_hints.h"
#include "node_inputs.h"
#include "node_output.h"
#include "node_params.h"
#include "node_places.h"
#include "node_visuals.h"
#include "pose_handoff.h"
#include "relocalize_service.h"
#include "service_call_queue.h"
#include "throttled_log.h"

namespace relocalizer_ros {

class RelocalizerNode {
 public:
  // Reads the parameters and loads the places; fails with one line naming the
  // parameter or file at fault (a place that does not load is only logged
  // while another one does, or while learning). Subscribes only once the model is ready, so a
  // publisher that waits for a subscriber (the replay player) waits for it.
  static relocalizer::Expected<std::unique_ptr<RelocalizerNode>> create(ros::NodeHandle nh,
                                                                        ros::NodeHandle private_nh);
  ~RelocalizerNode();
  RelocalizerNode(const RelocalizerNode&) = delete;
  RelocalizerNode& operator=(const RelocalizerNode&) = delete;

 private:
  using ResultMsg = NodeOutput::ResultMsg;

  RelocalizerNode(ros::NodeHandle nh, ros::NodeHandle private_nh, NodeParams params,
                  std::unique_ptr<NodePlaces> places,
                  std::unique_ptr<relocalizer::SubmapLearner> learner);

  void onFrame(FrameInputPtr input);
  void workerLoop();
  // Relocalizes one input and publishes its answer; `hint`: a service call's
  // own (else the pending initialpose hint, node_hints.h).
  ResultMsg process(const FrameInput& input, const relocalizer::PoseHint* hint = nullptr);
  ResultMsg processChecked(const FrameInput& input, NodeOutput::Clock::time_point start,
                           const relocalizer::PoseHint* hint);
  void fillCounters(ResultMsg& result) const;
  // Why no frame can be relocalized now: no place loaded, or learning has no model yet.
  std::string noPlaceReason() const;
  void logStartup() const;

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  const NodeParams params_;
  std::unique_ptr<tbb::global_control> thread_limit_;
  const std::unique_ptr<NodePlaces> places_;
  // Before every part that borrows it (see the lifetime rule above).
  tf2_ros::Buffer tf_;
  tf2_ros::TransformListener tf_listener_;

  std::atomic<uint64_t> frames_processed_{0};
  ThrottledLog log_;
  FrameBuffer<FrameInputPtr> frames_;
  NodeOutput output_;
  std::unique_ptr<NodeDiagnostics> diagnostics_;
  std::unique_ptr<NodeVisuals> visuals_;  // listens to output_ and places_
  std::unique_ptr<PoseHandoff> handoff_;  // listens to output_
  // Service calls: a thread each, so none waits behind another.
  ServiceCallQueue service_calls_;
  std::unique_ptr<LearningFeed> learning_;
  std::unique_ptr<NodeHints> hints_;
  std::unique_ptr<RelocalizeService> service_;
  std::thread worker_;
  // Last: destroyed first, so no input callback outlives what it feeds.
  std::unique_ptr<NodeInputs> inputs_;
};

}  // namespace relocalizer_ros
