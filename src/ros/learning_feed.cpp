#include "learning_feed.h"

#include <boost/bind/bind.hpp>
#include <filesystem>

#include "message_conversion.h"
#include "node_text.h"
#include "relocalizer/forest/training_config.h"

namespace relocalizer_ros {

relocalizer::Expected<std::unique_ptr<relocalizer::OnlineLearner>> LearningFeed::makeLearner(
    const NodeParams& params, const ros::NodeHandle& private_nh) {
  relocalizer::LearningParams learning;
  if (!params.learn_config.empty()) {
    auto training = relocalizer::loadTrainingParams(params.learn_config);
    if (!training)
      return relocalizer::makeError("'" + private_nh.resolveName("learn_config") + "': " + training.error());
    learning.training = *training;
  }
  learning.max_keyframes = params.learn_max_keyframes;
  learning.first_retrain = params.learn_first_retrain;
  learning.retrain_growth = params.learn_retrain_growth;
  learning.surface_gate = params.learn_surface_gate;
  auto learner = std::make_unique<relocalizer::OnlineLearner>(
      learning, params.relocalizer, relocalizer::OnlineLearner::Mode::Background);
  if (!params.model.empty()) {
    relocalizer::Status resumed = relocalizer::makeError("not loaded");
    try {
      resumed = learner->resume(params.model);
    } catch (const std::exception& e) {
      resumed = relocalizer::makeError(params.model + ": cannot be loaded: " + e.what());
    }
    if (!resumed) return relocalizer::makeError(resumed.error());
    // A pair left by an interrupted save resumes from its key frames alone;
    // the log says so as well as ~result's learning_error.
    if (const std::string why = learner->status().last_error; !why.empty())
      ROS_WARN("relocalizer: %s", why.c_str());
  }
  return learner;
}

LearningFeed::LearningFeed(ros::NodeHandle nh, ros::NodeHandle private_nh, const NodeParams& params,
                           std::unique_ptr<relocalizer::OnlineLearner> learner, ServiceCallQueue& calls)
    : params_(params), learner_(std::move(learner)) {
  auto save_options = ros::AdvertiseServiceOptions::create<relocalizer::SaveModel>(
      "save_model",
      boost::bind(&LearningFeed::onSaveModel, this, boost::placeholders::_1, boost::placeholders::_2),
      ros::VoidConstPtr(), &calls);
  save_service_ = private_nh.advertiseService(save_options);
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
  const auto motion = parseMinMotion(params_.learn_min_motion);  // checked by loadNodeParams
  key_frames_ = std::make_unique<KeyFrameSelector>(motion->first, motion->second);
  worker_ = std::thread(&LearningFeed::learnLoop, this);
}

void LearningFeed::close() {
  frames_.close();
  save_service_.shutdown();
}

LearningFeed::~LearningFeed() {
  close();
  if (worker_.joinable()) worker_.join();
  if (params_.save_on_exit.empty()) return;
  // The current model, not a final retrain: shutdown must stay quick, and
  // the key frames saved with it let the next run retrain on all of them.
  const relocalizer::Status saved = learner_->save(params_.save_on_exit);
  if (saved)
    ROS_INFO("relocalizer: saved the learned model to %s", params_.save_on_exit.c_str());
  else
    ROS_ERROR("relocalizer: save_on_exit: %s", saved.error().c_str());
}

void LearningFeed::fill(relocalizer::RelocalizationResult& result) const {
  const relocalizer::LearningStatus status = learner_->status();
  result.learning = true;
  result.keyframes_added = saturate(static_cast<uint64_t>(status.keyframes_added));
  result.keyframes_stored = saturate(static_cast<uint64_t>(status.keyframes_stored));
  result.keyframes_learned = saturate(static_cast<uint64_t>(status.keyframes_learned));
  result.learning_backlog = saturate(static_cast<uint64_t>(status.backlog));
  result.model_bytes = status.model_bytes;
  result.keyframe_bytes = status.store_bytes;
  result.frames_untracked = saturate(frames_untracked_);
  result.learning_error = status.last_error;
}

std::string LearningFeed::noModelYet() const {
  const relocalizer::LearningStatus status = learner_->status();
  return "no model yet: learning has " + std::to_string(status.keyframes_stored) +
         " key frames, the first model needs " + std::to_string(params_.learn_first_retrain) +
         (status.retraining ? " (being trained now)" : "") + "; is SLAM publishing " + params_.map_frame +
         " -> camera on TF?";
}

void LearningFeed::learnLoop() {
  while (true) {
    auto entry = frames_.take();
    if (!entry) return;
    const FrameInput& input = *entry->value;
    if (!input.error.empty()) continue;
    const ros::Time stamp = input.colour->header.stamp;
    const std::string camera_frame = stripLeadingSlashes(input.colour->header.frame_id);
    geometry_msgs::TransformStamped slam;
    try {
      // SLAM's pose at the frame's own stamp (interpolated), never a later
      // one: a frame whose stamp TF cannot cover was not tracked.
      slam = tf_buffer_->lookupTransform(params_.map_frame, camera_frame, stamp,
                                         ros::Duration(params_.tf_timeout));
    } catch (const tf2::TransformException& e) {
      ++frames_untracked_;
      if (log_.allow("learn: no TF"))
        ROS_INFO("relocalizer: not learning from the frame at %.3f: no pose %s -> %s from SLAM (%s)",
                 stamp.toSec(), params_.map_frame.c_str(), messageExcerpt(camera_frame).c_str(),
                 messageExcerpt(e.what(), 256).c_str());
      continue;
    }
    const relocalizer::Pose pose = fromTransformMsg(slam.transform);
    // Before the key-frame rule, which would otherwise measure later frames
    // against this pose; counted as untracked, since SLAM gave no usable pose.
    if (const std::string why = relocalizer::slamPoseError(pose); !why.empty()) {
      ++frames_untracked_;
      if (log_.allow("learn: bad SLAM pose"))
        ROS_WARN("relocalizer: not learning from the frame at %.3f: %s -> %s: %s", stamp.toSec(),
                 params_.map_frame.c_str(), camera_frame.c_str(), why.c_str());
      continue;
    }
    if (!key_frames_->keep(pose)) continue;
    auto frame = frameFromMessages(*input.colour, *input.depth, *input.info);
    if (!frame) {
      if (log_.allow(frame.error())) ROS_WARN("relocalizer: not learning from a frame: %s", frame.error().c_str());
      continue;
    }
    frame->id = static_cast<int>(entry->seq);
    if (relocalizer::Status added = learner_->addKeyFrame(*frame, pose); !added && log_.allow(added.error()))
      ROS_WARN("relocalizer: not learning from a key frame: %s", added.error().c_str());
  }
}

bool LearningFeed::onSaveModel(relocalizer::SaveModel::Request& request,
                                  relocalizer::SaveModel::Response& response) {
  if (request.path.empty()) {
    response.success = false;
    response.message = "path is empty: name the model file to write";
    return true;
  }
  // Relative to the node's working folder (ROS_HOME), which the caller does
  // not know: the answer names the file absolutely.
  std::error_code ignored;
  const std::string path = std::filesystem::absolute(request.path, ignored).lexically_normal().string();
  std::lock_guard<std::mutex> lock(save_mutex_);
  const relocalizer::Status saved = learner_->save(path);
  response.success = saved.ok();
  const relocalizer::LearningStatus status = learner_->status();
  response.message = saved ? "wrote " + path + " (trained on " +
                                 std::to_string(status.keyframes_learned) + " key frames) and " +
                                 relocalizer::keyFramesPath(path) + " (" +
                                 std::to_string(status.keyframes_stored) + " key frames)"
                           : saved.error();
  ROS_INFO("relocalizer: ~save_model: %s", response.message.c_str());
  return true;
}

}  // namespace relocalizer_ros
