#include "learning_feed.h"

#include <unistd.h>
#include <boost/bind/bind.hpp>
#include <cstdlib>
#include <filesystem>

#include "../conversion/message_conversion.h"
#include "node_text.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/online/submap_folder.h"

namespace relocalizer_ros {

namespace {

// The node's own folder: $ROS_HOME, else ~/.ros as roslaunch makes it.
std::filesystem::path rosHome() {
  const char* ros_home = std::getenv("ROS_HOME");
  const char* home = std::getenv("HOME");
  return ros_home && *ros_home ? ros_home : std::filesystem::path(home ? home : "/tmp") / ".ros";
}

// The one folder the node saves into (~save_model and save_on_exit).
std::string saveRoot(const LearnSettings& settings) {
  return settings.save_model_folder.empty() ? (rosHome() / "relocalizer").string()
                                            : settings.save_model_folder;
}

}  // namespace

relocalizer::Expected<std::unique_ptr<relocalizer::SubmapLearner>> LearningFeed::makeLearner(
    LearnSettings& settings, const std::string& model, relocalizer::SubmapNames names,
    const relocalizer::RelocalizerParams& relocalizer) {
  // The exit's save writes where a ~save_model could (issue 38, S1): refused
  // now, loudly, rather than after a run's learning. From here on the
  // parameter is the folder resolved.
  if (!settings.save_on_exit.empty()) {
    auto confined = relocalizer::confinedSaveFolder(saveRoot(settings), settings.save_on_exit);
    if (!confined) return relocalizer::makeError("save_on_exit: " + confined.error());
    settings.save_on_exit = *confined;
  }
  auto learner = std::make_unique<relocalizer::SubmapLearner>(
      settings.learning, settings.submaps, relocalizer, std::move(names),
      relocalizer::OnlineLearner::Mode::Background);
  if (!model.empty()) {
    relocalizer::Expected<std::vector<std::string>> resumed = relocalizer::makeError("not loaded");
    try {
      resumed = learner->resume(model);
    } catch (const std::exception& e) {
      resumed = relocalizer::makeError(model +
                                       ": cannot be loaded: " + relocalizer::loadFailureReason(e));
    }
    if (!resumed) return relocalizer::makeError(resumed.error());
    // A submap that could not be loaded is skipped, and a pair left by an
    // interrupted save resumes from its key frames alone: each is logged.
    for (const std::string& warning : *resumed) ROS_WARN("relocalizer: %s", warning.c_str());
  }
  // Frozen submaps go to disk as they freeze, so memory stays bounded
  // (submap_learner.h): into save_on_exit, which the exit writes anyway.
  if (!settings.save_on_exit.empty()) {
    if (const relocalizer::Status working = learner->useFolder(settings.save_on_exit); !working)
      return relocalizer::makeError("save_on_exit: " + working.error());
  }
  return learner;
}

LearningFeed::LearningFeed(ros::NodeHandle private_nh, const LearnSettings& settings,
                           const TfSettings& tf_settings, tf2_ros::Buffer& tf,
                           std::unique_ptr<relocalizer::SubmapLearner> learner,
                           ServiceCallQueue& calls)
    : settings_(settings),
      tf_settings_(tf_settings),
      learner_(std::move(learner)),
      feed_(*learner_, settings.learning),
      tf_buffer_(tf) {
  auto save_options = ros::AdvertiseServiceOptions::create<relocalizer::SaveModel>(
      "save_model",
      boost::bind(&LearningFeed::onSaveModel, this, boost::placeholders::_1,
                  boost::placeholders::_2),
      ros::VoidConstPtr(), &calls);
  save_service_ = private_nh.advertiseService(save_options);
  worker_ = std::thread(&LearningFeed::learnLoop, this);
}

void LearningFeed::close() {
  frames_.close();
  save_service_.shutdown();
}

LearningFeed::~LearningFeed() {
  close();
  if (worker_.joinable()) worker_.join();
  if (settings_.save_on_exit.empty()) return;
  // The active submap's current model, not a final retrain: shutdown must
  // stay quick, and the key frames saved with it let the next run retrain on
  // all of them.
  const relocalizer::Status saved = learner_->save(settings_.save_on_exit);
  if (saved)
    ROS_INFO("relocalizer: saved the learned submaps to %s", settings_.save_on_exit.c_str());
  else
    ROS_ERROR("relocalizer: save_on_exit: %s", saved.error().c_str());
}

void LearningFeed::fill(relocalizer::RelocalizationResult& result) const {
  const relocalizer::SubmapStatus status = learner_->status();
  result.learning = true;
  result.keyframes_added = saturate(static_cast<uint64_t>(status.keyframes_added));
  result.keyframes_stored = saturate(static_cast<uint64_t>(status.active.keyframes_stored));
  result.keyframes_learned = saturate(static_cast<uint64_t>(status.active.keyframes_learned));
  result.learning_backlog = saturate(static_cast<uint64_t>(status.active.backlog));
  result.model_bytes = status.model_bytes;
  result.keyframe_bytes = status.active.store_bytes;
  result.frames_untracked = saturate(frames_untracked_);
  result.learning_frames_skipped = saturate(frames_.dropped());
  result.submaps = saturate(static_cast<uint64_t>(status.submaps));
  result.keyframes_covered = saturate(static_cast<uint64_t>(status.keyframes_covered));
  result.learning_error = status.last_error;
  const relocalizer::SlamCheckStatus check = feed_.check().status();
  result.slam_poses_refused = saturate(static_cast<uint64_t>(check.refused));
  result.learning_stopped = check.map_moved;
  // Louder than a failed retrain: every key frame is refused until SLAM's
  // poses agree with the place again.
  if (check.map_moved) result.learning_error = check.map_moved_why;
}

std::string LearningFeed::noModelYet() const {
  const relocalizer::SubmapStatus status = learner_->status();
  return "no model yet: learning has " + std::to_string(status.active.keyframes_stored) +
         " key frames, the first model needs " + std::to_string(settings_.learning.first_retrain) +
         (status.active.retraining ? " (being trained now)" : "") + "; is SLAM publishing " +
         tf_settings_.map_frame + " -> camera on TF?";
}

void LearningFeed::learnLoop() {
  using Outcome = relocalizer::KeyFrameFeed::Result::Outcome;
  int submaps = learner_->index().submapCount();
  while (true) {
    auto entry = frames_.take();
    if (!entry) return;
    const FrameInput& input = *entry->value;
    if (!input.error.empty()) continue;
    const ros::Time stamp = geometryStamp(input);
    const std::string camera_frame = stripLeadingSlashes(input.colour->header.frame_id);
    std::optional<relocalizer::Pose> pose;
    try {
      // SLAM's pose when the depth, whose points become the labels, was taken
      // (interpolated), never a later one: a frame whose stamp TF cannot
      // cover was not tracked.
      pose = fromTransformMsg(tf_buffer_
                                  .lookupTransform(tf_settings_.map_frame, camera_frame, stamp,
                                                   ros::Duration(tf_settings_.tf_timeout))
                                  .transform);
    } catch (const tf2::TransformException& e) {
      if (log_.allow("learn: no TF"))
        ROS_INFO(
            "relocalizer: not learning from the frame at %.3f: no pose %s -> %s from SLAM (%s)",
            stamp.toSec(), tf_settings_.map_frame.c_str(), messageExcerpt(camera_frame).c_str(),
            messageExcerpt(e.what(), 256).c_str());
    }
    const relocalizer::KeyFrameFeed::Result fed = feed_.offer(pose, [&] {
      auto frame = frameFromMessages(*input.colour, *input.depth, *input.info);
      if (frame) frame->id = static_cast<int>(entry->seq);
      return frame;
    });
    // A new submap froze the one before: it needs a folder to go to.
    if (const int now = learner_->index().submapCount(); now != submaps) {
      if (submaps > 0) keepFrozenOnDisk();
      submaps = now;
    }
    if (fed.outcome == Outcome::Untracked) {
      ++frames_untracked_;  // no pose, or one SLAM got wrong (fed.why)
      if (!fed.why.empty() && log_.allow("learn: bad SLAM pose"))
        ROS_WARN("relocalizer: not learning from the frame at %.3f: %s -> %s: %s", stamp.toSec(),
                 tf_settings_.map_frame.c_str(), messageExcerpt(camera_frame).c_str(),
                 fed.why.c_str());
    } else if (fed.outcome == Outcome::Failed && log_.allow(fed.why)) {
      ROS_WARN("relocalizer: not learning from a key frame: %s", fed.why.c_str());
    } else if (!fed.map_moved.empty()) {
      ROS_ERROR("relocalizer: %s", fed.map_moved.c_str());  // a new place, or learning stopped
    } else if (fed.outcome == Outcome::Refused && log_.allow("learn: SLAM pose refused")) {
      ROS_WARN("relocalizer: not learning from the frame at %.3f (%d refused so far): %s",
               stamp.toSec(), feed_.check().status().refused, fed.why.c_str());
    }
  }
}

void LearningFeed::keepFrozenOnDisk() {
  if (!learner_->workingFolder().empty()) return;
  // Without a folder to write to, every frozen submap would keep its key
  // frames in memory until the first save: a folder of this run's own.
  const std::string folder =
      (rosHome() / ("relocalizer_learned_" + std::to_string(::getpid()) + "_" +
                    std::to_string(static_cast<long>(ros::WallTime::now().toSec()))))
          .string();
  if (const relocalizer::Status working = learner_->useFolder(folder); !working) {
    if (log_.allow("learn: working folder"))
      ROS_WARN("relocalizer: frozen submaps stay in memory until ~save_model: %s",
               working.error().c_str());
    return;
  }
  ROS_INFO(
      "relocalizer: frozen submaps are written to %s (~save_model or save_on_exit copies them)",
      folder.c_str());
}

bool LearningFeed::onSaveModel(relocalizer::SaveModel::Request& request,
                               relocalizer::SaveModel::Response& response) {
  // A peer's path: inside save_model_folder only (submap_folder.h), relative
  // ones too; the answer names the folder written absolutely.
  const std::string root = saveRoot(settings_);
  relocalizer::Status saved = relocalizer::okStatus();
  std::string path;
  try {
    auto confined = relocalizer::confinedSaveFolder(root, request.path);
    if (confined) {
      path = *confined;
      std::lock_guard<std::mutex> lock(save_mutex_);
      saved = learner_->save(path);
    } else {
      saved = relocalizer::makeError(confined.error());
    }
  } catch (const std::exception&) {
    // An answer, never a service error: the caller learns the save failed.
    saved = relocalizer::makeError("the save failed (out of memory, or the file system refused)");
  }
  response.success = saved.ok();
  const relocalizer::SubmapStatus status = learner_->status();
  int keyframes = 0;
  for (int count : status.submap_keyframes) keyframes += count;
  response.message = saved ? "wrote " + path + " (" + std::to_string(status.submaps) +
                                 " submaps, " + std::to_string(keyframes) + " key frames)"
                           : saved.error();
  ROS_INFO("relocalizer: ~save_model: %s", response.message.c_str());
  return true;
}

}  // namespace relocalizer_ros
