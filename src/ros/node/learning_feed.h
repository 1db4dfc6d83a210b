#pragma once
// Learn mode's feed from SLAM into the online learner: the newest synchronised
// frame is posed by TF map_frame -> camera at its own stamp (never a later
// one: a frame TF cannot cover was not tracked), checked, filtered by the
// key-frame rule, its SLAM motion checked against its images (jumps and map
// resets are refused, counted and logged: slam_pose_check.h) and handed to
// the submap learner (submap_learner.h), all by the one feed (key_frame_feed.h): the
// active submap's own low-priority worker retrains, and a full submap is
// frozen. Also ~save_model and save_on_exit.
//
// Threads: push() from the input callbacks (O(1)); one learning thread; the
// save service on the node's service calls queue.
//
// A freeze (the full submap's last retrain, seconds) runs on the learner's
// freeze thread (Background mode), neither on this thread nor on a
// relocalization's: relocalizations go on with the frozen submap's last model
// until its final one is put. This thread waits only when a second freeze
// comes while the first still runs; frames that arrive while it waits (or
// stores a key frame, or waits for TF) replace one another in the Latest
// buffer and are counted in ~result's learning_frames_skipped.

#include <relocalizer/RelocalizationResult.h>
#include <relocalizer/SaveModel.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <thread>

#include "frame_buffer.h"
#include "frame_input.h"
#include "learn_settings.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/online/key_frame_feed.h"
#include "relocalizer/online/submap_learner.h"
#include "service_call_queue.h"
#include "tf_settings.h"
#include "throttled_log.h"

namespace relocalizer_ros {

class LearningFeed {
 public:
  // The learner the settings describe, its submaps named by `names` (the
  // learned place, placeName(), in map_frame), resumed from `model` when set;
  // the error names the file at fault. save_on_exit must lie in the save
  // folder (confinedSaveFolder, as ~save_model's path): it becomes the folder
  // resolved.
  static relocalizer::Expected<std::unique_ptr<relocalizer::SubmapLearner>> makeLearner(
      LearnSettings& settings, const std::string& model, relocalizer::SubmapNames names,
      const relocalizer::RelocalizerParams& relocalizer);

  // SLAM's pose is TF map_frame -> camera, waited for up to tf_timeout;
  // `tf`: the node's buffer (relocalizer_node.h), read on the learning
  // thread; it outlives this.
  LearningFeed(ros::NodeHandle private_nh, const LearnSettings& settings,
               const TfSettings& tf_settings, tf2_ros::Buffer& tf,
               std::unique_ptr<relocalizer::SubmapLearner> learner, ServiceCallQueue& calls);
  // Stops the learning thread, then writes save_on_exit if set.
  ~LearningFeed();
  LearningFeed(const LearningFeed&) = delete;
  LearningFeed& operator=(const LearningFeed&) = delete;

  void push(FrameInputPtr input) { frames_.push(std::move(input)); }
  // Ends the learning thread's wait and the save service; the destructor does the rest.
  void close();

  relocalizer::SubmapStatus status() const { return learner_->status(); }
  // Learn mode's fields of ~result.
  void fill(relocalizer::RelocalizationResult& result) const;
  // "no model yet" with what learning has so far, for frames that come too early.
  std::string noModelYet() const;

 private:
  void learnLoop();
  // At the first new submap, when neither save_on_exit nor a continued
  // folder gave one: a working folder under ROS_HOME for frozen submaps.
  void keepFrozenOnDisk();
  bool onSaveModel(relocalizer::SaveModel::Request& request,
                   relocalizer::SaveModel::Response& response);

  const LearnSettings& settings_;
  const TfSettings& tf_settings_;
  const std::unique_ptr<relocalizer::SubmapLearner> learner_;
  relocalizer::KeyFrameFeed feed_;  // into learner_; offered to on the learning thread
  // The newest frame only: key frames are chosen by motion, so a skipped
  // frame is covered by the next.
  FrameBuffer<FrameInputPtr> frames_{FrameBuffer<FrameInputPtr>::Policy::Latest};
  tf2_ros::Buffer& tf_buffer_;
  std::atomic<uint64_t> frames_untracked_{0};  // frames without a (usable) SLAM pose
  std::mutex save_mutex_;  // one save at a time: two saves of one path share its temporary files
  ThrottledLog log_;
  ros::ServiceServer save_service_;
  std::thread worker_;
};

}  // namespace relocalizer_ros
