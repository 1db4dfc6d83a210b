#include "relocalizer_node.h"

#include <boost/bind/bind.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "message_conversion.h"
#include "relocalizer/forest/training_config.h"

namespace relocalizer_ros {

namespace {

using Clock = std::chrono::steady_clock;

int64_t steadyNanoseconds() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

std::string seconds(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", value);
  return text;
}

// Seconds with millisecond precision, from integer nanoseconds (no double
// rounding, no ros::Time arithmetic on stamps that may be absurd).
std::string formatStamp(int64_t stamp_ns) {
  char text[40];
  std::snprintf(text, sizeof(text), "%lld.%03lld", static_cast<long long>(stamp_ns / 1'000'000'000),
                static_cast<long long>((stamp_ns % 1'000'000'000) / 1'000'000));
  return text;
}

uint32_t saturate(uint64_t value) {
  return value > UINT32_MAX ? UINT32_MAX : static_cast<uint32_t>(value);
}

// Service calls that can wait or compute at once; further ones queue, and
// their wait counts from their arrival. Far more than any SLAM stack makes.
constexpr size_t kServiceThreads = 64;
// A process_all backlog this long means the source outruns the node: the
// replay player paces itself, rosbag play does not.
constexpr size_t kBacklogWarning = 30;
// Time jumps are logged one line each, at most this often (a source whose
// stamps jitter backwards on every frame must not flood the log).
constexpr std::chrono::seconds kJumpLogPeriod{1};
// A call that waited this long for a thread before it ran says so.
constexpr double kQueuedReportSeconds = 0.1;

const char* const kInputNames[3] = {"colour", "depth", "camera_info"};

}  // namespace

relocalizer::Expected<std::unique_ptr<RelocalizerNode>> RelocalizerNode::create(
    ros::NodeHandle nh, ros::NodeHandle private_nh) {
  auto params = loadNodeParams(private_nh);
  if (!params) return relocalizer::makeError(params.error());
  if (params->learn) {
    relocalizer::LearningParams learning;
    if (!params->learn_config.empty()) {
      auto training = relocalizer::loadTrainingParams(params->learn_config);
      if (!training)
        return relocalizer::makeError("'" + private_nh.resolveName("learn_config") + "': " + training.error());
      learning.training = *training;
    }
    learning.max_keyframes = params->learn_max_keyframes;
    learning.first_retrain = params->learn_first_retrain;
    learning.retrain_growth = params->learn_retrain_growth;
    learning.surface_gate = params->learn_surface_gate;
    auto learner = std::make_unique<relocalizer::OnlineLearner>(
        learning, params->relocalizer, relocalizer::OnlineLearner::Mode::Background);
    if (!params->model.empty()) {
      relocalizer::Status resumed = relocalizer::makeError("not loaded");
      try {
        resumed = learner->resume(params->model);
      } catch (const std::exception& e) {
        resumed = relocalizer::makeError(params->model + ": cannot be loaded: " + e.what());
      }
      if (!resumed) return relocalizer::makeError(resumed.error());
      // A pair left by an interrupted save resumes from its key frames alone;
      // the log says so as well as ~result's learning_error.
      if (const std::string why = learner->status().last_error; !why.empty())
        ROS_WARN("relocalizer: %s", why.c_str());
    }
    return std::unique_ptr<RelocalizerNode>(new RelocalizerNode(
        std::move(nh), std::move(private_nh), std::move(*params), nullptr, std::move(learner)));
  }
  relocalizer::Expected<std::unique_ptr<relocalizer::Relocalizer>> relocalizer =
      relocalizer::makeError("not loaded");
  try {
    relocalizer = relocalizer::Relocalizer::fromFile(params->model, params->relocalizer);
  } catch (const std::exception& e) {
    // Whatever the loader throws (e.g. std::bad_alloc on a corrupt size) is
    // one line and exit code 1 too, never an abort.
    return relocalizer::makeError(params->model + ": cannot be loaded: " + e.what());
  }
  if (!relocalizer) return relocalizer::makeError(relocalizer.error());
  if (std::string why = (*relocalizer)->validationError(); !why.empty())
    return relocalizer::makeError(params->model + ": " + why);
  return std::unique_ptr<RelocalizerNode>(new RelocalizerNode(std::move(nh), std::move(private_nh),
                                                              std::move(*params),
                                                              std::move(*relocalizer), nullptr));
}

RelocalizerNode::RelocalizerNode(ros::NodeHandle nh, ros::NodeHandle private_nh, NodeParams params,
                                 std::shared_ptr<const relocalizer::Relocalizer> relocalizer,
                                 std::unique_ptr<relocalizer::OnlineLearner> learner)
    : nh_(std::move(nh)),
      private_nh_(std::move(private_nh)),
      params_(std::move(params)),
      thread_limit_(params_.threads > 0 ? std::make_unique<tbb::global_control>(
                                              tbb::global_control::max_allowed_parallelism,
                                              static_cast<size_t>(params_.threads))
                                        : nullptr),
      fixed_model_(std::move(relocalizer)),
      learner_(std::move(learner)),
      frames_(params_.mode == Mode::Continuous && params_.process_all
                  ? FrameBuffer<InputPtr>::Policy::Fifo
                  : FrameBuffer<InputPtr>::Policy::Latest),
      start_ns_(steadyNanoseconds()),
      service_calls_(kServiceThreads) {
  pose_pub_ = private_nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 1, true);
  result_pub_ = private_nh_.advertise<ResultMsg>("result", 10);
  if (params_.publish_tf) {
    TransformPublisher::Options options;
    options.map_frame = params_.map_frame;
    options.odom_frame = params_.odom_frame;
    options.transform_tolerance = params_.transform_tolerance;
    options.tf_rate = params_.tf_rate;
    options.tf_timeout = params_.tf_timeout;
    transforms_ = std::make_unique<TransformPublisher>(nh_, options);
  }

  auto service_options = ros::AdvertiseServiceOptions::create<relocalizer::Relocalize>(
      "relocalize",
      boost::bind(&RelocalizerNode::onRelocalize, this, boost::placeholders::_1,
                  boost::placeholders::_2),
      ros::VoidConstPtr(), &service_calls_);
  service_ = private_nh_.advertiseService(service_options);

  if (learner_) {
    auto save_options = ros::AdvertiseServiceOptions::create<relocalizer::SaveModel>(
        "save_model",
        boost::bind(&RelocalizerNode::onSaveModel, this, boost::placeholders::_1,
                    boost::placeholders::_2),
        ros::VoidConstPtr(), &service_calls_);
    save_service_ = private_nh_.advertiseService(save_options);
    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh_);
    const auto motion = parseMinMotion(params_.learn_min_motion);  // checked by loadNodeParams
    key_frames_ = std::make_unique<KeyFrameSelector>(motion->first, motion->second);
    learn_worker_ = std::thread(&RelocalizerNode::learnLoop, this);
  }
  if (params_.mode == Mode::Continuous) worker_ = std::thread(&RelocalizerNode::workerLoop, this);
  if (params_.input_timeout > 0.0)
    watchdog_ = nh_.createWallTimer(ros::WallDuration(1.0), &RelocalizerNode::onWatchdog, this);
  subscribe();

  const std::shared_ptr<const relocalizer::Relocalizer> current = currentModel();
  std::string model_text;
  if (current) {
    const relocalizer::Model& model = current->model();
    model_text = "model " + (params_.model.empty() ? std::string("(learned)") : params_.model) + " (" +
                 std::to_string(model.points.trees.size()) + " point trees, " +
                 std::to_string(model.lines.trees.size()) + " line trees)";
  } else {
    model_text = "no model yet";
  }
  if (learner_) {
    const relocalizer::LearningStatus status = learner_->status();
    model_text += std::string(", learning from TF ") + params_.map_frame + " -> camera (" +
                  std::to_string(status.keyframes_stored) + " key frames so far, key frames at " +
                  params_.learn_min_motion + " m,deg" +
                  (params_.save_on_exit.empty() ? "" : ", saved to " + params_.save_on_exit + " on exit") + ")";
  }
  const std::string tf_text =
      !params_.publish_tf ? "no TF"
      : params_.odom_frame.empty()
          ? params_.map_frame + " -> camera TF"
          : params_.map_frame + " -> " + params_.odom_frame + " TF";
  const std::string mode_text =
      params_.mode == Mode::OnDemand
          ? "on demand (call " + service_.getService() + ")"
          : std::string("continuous") +
                (params_.max_rate > 0 ? " at up to " + seconds(params_.max_rate) + " Hz" : "") +
                (params_.process_all ? ", every frame" : "");
  ROS_INFO("relocalizer: %s, %s, %s; frames from %s, %s, %s", model_text.c_str(), mode_text.c_str(),
           tf_text.c_str(), colour_sub_.getTopic().c_str(), depth_sub_.getTopic().c_str(),
           info_sub_.getTopic().c_str());
  if (current)
    if (const std::string limits = current->limitations(); !limits.empty())
      ROS_WARN("relocalizer: %s: %s", params_.model.c_str(), limits.c_str());
}

std::shared_ptr<const relocalizer::Relocalizer> RelocalizerNode::currentModel() const {
  return learner_ ? learner_->current() : fixed_model_;
}

void RelocalizerNode::learnLoop() {
  while (true) {
    auto entry = learn_frames_.take();
    if (!entry) return;
    const Input& input = *entry->value;
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

bool RelocalizerNode::onSaveModel(relocalizer::SaveModel::Request& request,
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
  // One save at a time: two saves of one path would share its temporary files.
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

RelocalizerNode::~RelocalizerNode() {
  // No input callback may run past this point (roscpp waits for one in
  // progress): they use the synchronizer and the frame buffer.
  colour_sub_.unsubscribe();
  depth_sub_.unsubscribe();
  info_sub_.unsubscribe();
  // Wake every waiter first, so neither the worker nor a service call blocks
  // the joins below.
  frames_.close();
  learn_frames_.close();
  watchdog_.stop();
  service_.shutdown();
  save_service_.shutdown();
  service_calls_.stop();
  if (worker_.joinable()) worker_.join();
  if (learn_worker_.joinable()) learn_worker_.join();
  if (learner_ && !params_.save_on_exit.empty()) {
    // The current model, not a final retrain: shutdown must stay quick, and
    // the key frames saved with it let the next run retrain on all of them.
    const relocalizer::Status saved = learner_->save(params_.save_on_exit);
    if (saved)
      ROS_INFO("relocalizer: saved the learned model to %s", params_.save_on_exit.c_str());
    else
      ROS_ERROR("relocalizer: save_on_exit: %s", saved.error().c_str());
  }
}

void RelocalizerNode::subscribe() {
  image_transport_ = std::make_unique<image_transport::ImageTransport>(nh_);
  // Lets users pick compressed transports with ~image_transport, as image_proc does.
  const image_transport::TransportHints hints("raw", ros::TransportHints(), private_nh_);
  const uint32_t queue = static_cast<uint32_t>(params_.sync_queue_size);
  colour_sub_.subscribe(*image_transport_, "rgb/image", queue, hints);
  depth_sub_.subscribe(*image_transport_, "depth/image", queue, hints);
  info_sub_.subscribe(nh_, "rgb/camera_info", queue);

  InputSynchronizer::Options options;
  options.approximate = params_.approx_sync;
  options.queue_size = static_cast<uint32_t>(params_.sync_queue_size);
  options.max_interval = params_.max_interval;
  InputSynchronizer::Events events;
  events.on_set = [this](const sensor_msgs::ImageConstPtr& colour, const sensor_msgs::ImageConstPtr& depth,
                         const sensor_msgs::CameraInfoConstPtr& info) { onSynchronised(colour, depth, info); };
  events.on_jump = [this](const StampGate::Jump& jump) { onTimeJump(jump); };
  events.on_drop = [this](int input, StampGate::Drop why, int64_t stamp_ns) {
    onStampDropped(input, why, stamp_ns);
  };
  inputs_ = std::make_unique<InputSynchronizer>(options, std::move(events));
  // Per-topic counts, so "no frame" can say which input is missing; then the
  // time check and the synchronizer.
  colour_sub_.registerCallback([this](const sensor_msgs::ImageConstPtr& image) {
    ++colour_count_;
    last_image_ns_ = steadyNanoseconds();
    {
      std::lock_guard<std::mutex> lock(stamp_mutex_);
      last_image_stamp_ = image->header.stamp;
    }
    onInput<0>(image);
  });
  depth_sub_.registerCallback([this](const sensor_msgs::ImageConstPtr& image) {
    ++depth_count_;
    last_image_ns_ = steadyNanoseconds();
    onInput<1>(image);
  });
  info_sub_.registerCallback([this](const sensor_msgs::CameraInfoConstPtr& info) {
    ++info_count_;
    onInput<2>(info);
  });
}

template <int I, typename M>
void RelocalizerNode::onInput(const boost::shared_ptr<M const>& message) {
  std::lock_guard<std::mutex> lock(input_mutex_);
  try {
    inputs_->add<I>(message, Clock::now());
  } catch (const std::exception& e) {
    // The stamp gate keeps message_filters' arithmetic in range (fuzz_stamps
    // checks it); should anything else throw, one message is lost, not the node.
    ++messages_dropped_;
    if (log_.allow("synchronizer error"))
      ROS_ERROR("relocalizer: dropped a message on %s: %s", inputTopic(I).c_str(), e.what());
  }
}

std::string RelocalizerNode::inputTopic(int input) const {
  return input == 0 ? colour_sub_.getTopic() : input == 1 ? depth_sub_.getTopic() : info_sub_.getTopic();
}

void RelocalizerNode::onStampDropped(int input, StampGate::Drop why, int64_t stamp_ns) {
  ++messages_dropped_;
  const std::string stamp = formatStamp(stamp_ns);
  std::string text;
  switch (why) {
    case StampGate::Drop::BeyondRange:
      text = "stamped " + stamp + " s, at or past 2^31 s (the year 2038), where ROS time arithmetic "
             "overflows: an uninitialised driver stamp?";
      break;
    case StampGate::Drop::OutOfOrder:
      text = "stamped " + stamp + " s, before the previous message on it (out of order by less than " +
             seconds(1e-9 * StampGate::kMinJumpNs) + " s, too little for a jump)";
      break;
    case StampGate::Drop::Unconfirmed:
      text = "stamped " + stamp + " s, off the other messages' timeline, and no later message "
             "followed it there: a glitch, not a jump";
      break;
    case StampGate::Drop::OldTimeline:  // expected after every jump: counted, not logged
    case StampGate::Drop::None: return;
  }
  const std::string key = "stamp drop " + std::to_string(static_cast<int>(why));
  if (log_.allow(key))
    ROS_WARN("relocalizer: dropped a %s message on %s %s", kInputNames[input], inputTopic(input).c_str(),
             text.c_str());
}

void RelocalizerNode::onTimeJump(const StampGate::Jump& jump) {
  // The frames waiting to be relocalized are from the old timeline, and tf2
  // would refuse the new timeline's odom -> camera as older than what it holds.
  const uint64_t jumps = ++time_jumps_;
  const size_t dropped = frames_.clear();
  if (transforms_) transforms_->reset();

  const int64_t step = jump.to_ns - jump.from_ns;
  const std::string what = std::string(step < 0 ? "stamps went back in time by " : "stamps jumped forward by ") +
                           seconds(1e-9 * static_cast<double>(step < 0 ? -step : step)) + " s on " +
                           inputTopic(jump.input) + " (" + kInputNames[jump.input] + ", " +
                           formatStamp(jump.to_ns) + " after " + formatStamp(jump.from_ns) + ")";
  const std::string done = std::string("; a looping bag or a restarted source? synchronizer reset, ") +
                           std::to_string(dropped) + " pending frame" + (dropped == 1 ? "" : "s") +
                           " dropped" + (transforms_ && !params_.odom_frame.empty() ? ", TF buffer cleared" : "");
  const auto now = Clock::now();
  if (jumps == 1 || now - last_jump_log_ >= kJumpLogPeriod) {
    const std::string more =
        unlogged_jumps_ ? " (" + std::to_string(unlogged_jumps_) + " more jumps since the last report)" : "";
    ROS_WARN("relocalizer: %s%s; jump %llu%s", what.c_str(), done.c_str(),
             static_cast<unsigned long long>(jumps), more.c_str());
    last_jump_log_ = now;
    unlogged_jumps_ = 0;
  } else {
    ++unlogged_jumps_;
  }
  if (params_.mode == Mode::Continuous) {
    // Continuous consumers follow ~result only; tell them as the watchdog does.
    ros::Time stamp;
    stamp.fromNSec(static_cast<uint64_t>(jump.to_ns));
    ResultMsg result = failure(stamp, what + "; synchronizer and frame buffer reset");
    publishOutcome(result, nullptr, nullptr, std::nullopt, false);
  }
}

void RelocalizerNode::onSynchronised(const sensor_msgs::ImageConstPtr& colour,
                                     const sensor_msgs::ImageConstPtr& depth,
                                     const sensor_msgs::CameraInfoConstPtr& info) {
  auto input = std::make_shared<Input>();
  input->colour = colour;
  input->depth = depth;
  input->info = info;
  input->error = checkFrameMessages(*colour, *depth, *info);
  input->epoch = time_jumps_.load();
  ++frames_received_;
  last_frame_ns_ = steadyNanoseconds();
  colour_at_sync_ = colour_count_.load();
  depth_at_sync_ = depth_count_.load();
  info_at_sync_ = info_count_.load();
  if (!input->error.empty() && log_.allow(input->error))
    ROS_WARN("relocalizer: unusable frame on %s: %s", colour_sub_.getTopic().c_str(),
             input->error.c_str());
  if (learner_) learn_frames_.push(input);
  frames_.push(std::move(input));
  if (params_.process_all && params_.mode == Mode::Continuous &&
      frames_.pendingCount() > kBacklogWarning && log_.allow("backlog"))
    ROS_WARN("relocalizer: %zu frames wait to be relocalized (process_all): the source is faster "
             "than the node, and latency grows; pace it (replay.launch does) or slow it down",
             frames_.pendingCount());
}

void RelocalizerNode::onWatchdog(const ros::WallTimerEvent&) {
  const int64_t now = steadyNanoseconds();
  const double timeout = params_.input_timeout;
  const double since_start = 1e-9 * static_cast<double>(now - start_ns_);
  const int64_t last_image = last_image_ns_.load();
  const int64_t last_frame = last_frame_ns_.load();
  const double since_image = last_image ? 1e-9 * static_cast<double>(now - last_image) : since_start;
  const double since_frame = last_frame ? 1e-9 * static_cast<double>(now - last_frame) : since_start;
  if (since_image < timeout && since_frame >= timeout) {
    // Images flow but never form a set: a missing camera_info, or stamps that
    // never match. Nothing else would ever report it, so the watchdog does.
    const std::string why = "images arrive but no synchronised frame for " + seconds(since_frame) +
                            " s; " + inputStatus();
    if (log_.allow("unsynchronised")) ROS_WARN("relocalizer: %s", why.c_str());
    if (params_.mode == Mode::Continuous) {
      ros::Time stamp;
      {
        std::lock_guard<std::mutex> lock(stamp_mutex_);
        stamp = last_image_stamp_;
      }
      ResultMsg result = failure(stamp, why);
      publishOutcome(result, nullptr, nullptr, std::nullopt, false);
    }
  } else if (since_image >= timeout && since_frame >= timeout && log_.allow("no input")) {
    ROS_WARN("relocalizer: no image for %s s on %s or %s", seconds(since_image).c_str(),
             colour_sub_.getTopic().c_str(), depth_sub_.getTopic().c_str());
  }
}

std::string RelocalizerNode::inputStatus() const {
  const uint64_t colour = colour_count_ - colour_at_sync_;
  const uint64_t depth = depth_count_ - depth_at_sync_;
  const uint64_t info = info_count_ - info_at_sync_;
  const uint64_t sets = frames_received_;
  std::string status = "received " + std::to_string(colour) + " on " + colour_sub_.getTopic() + ", " +
                       std::to_string(depth) + " on " + depth_sub_.getTopic() + ", " +
                       std::to_string(info) + " on " + info_sub_.getTopic() +
                       (sets ? " since the last synchronised frame" : " and no synchronised frame yet");
  if (colour == 0 || depth == 0 || info == 0) {
    status += "; is every topic published?";
  } else {
    status += params_.approx_sync
                  ? "; do the stamps differ by more than max_interval (" +
                        seconds(params_.max_interval) + " s)?"
                  : "; approx_sync is false but the stamps differ";
  }
  return status;
}

void RelocalizerNode::workerLoop() {
  const auto period = params_.max_rate > 0.0
                          ? std::chrono::duration_cast<Clock::duration>(
                                std::chrono::duration<double>(1.0 / params_.max_rate))
                          : Clock::duration::zero();
  Clock::time_point next_start = Clock::now();
  // Waiting for the rate slot before taking a frame means the frame processed
  // is the newest one, not one that aged while the worker slept.
  while (frames_.sleepUntil(next_start)) {
    auto entry = frames_.take();
    if (!entry) break;
    next_start = Clock::now() + period;
    process(*entry->value);
  }
}

RelocalizerNode::ResultMsg RelocalizerNode::failure(const ros::Time& stamp,
                                                    const std::string& message) const {
  ResultMsg result;
  result.header.stamp = stamp;
  result.header.frame_id = params_.map_frame;
  result.success = false;
  result.message = message;
  result.surface_agreement = -1.0f;  // not checked
  return result;
}

RelocalizerNode::ResultMsg RelocalizerNode::process(const Input& input) {
  const auto start = Clock::now();
  const ros::Time stamp = input.colour->header.stamp;
  ++frames_processed_;
  ResultMsg result = failure(stamp, input.error);
  if (!input.error.empty()) {
    // Already logged when it arrived.
    publishOutcome(result, nullptr, nullptr, std::nullopt, true);
    return result;
  }
  try {
    return processChecked(input, start);
  } catch (const std::exception& e) {
    // A frame the core chokes on must cost one failure result, not the node
    // (or, through an unset promise, every waiting service call).
    result.message = std::string("internal error: ") + e.what();
    ROS_ERROR("relocalizer: frame at %.3f: %s", stamp.toSec(), result.message.c_str());
    result.processing_time = std::chrono::duration<float>(Clock::now() - start).count();
    publishOutcome(result, nullptr, nullptr, std::nullopt, true);
    return result;
  }
}

RelocalizerNode::ResultMsg RelocalizerNode::processChecked(const Input& input,
                                                           Clock::time_point start) {
  const ros::Time stamp = input.colour->header.stamp;
  ResultMsg result = failure(stamp, "");
  auto frame = frameFromMessages(*input.colour, *input.depth, *input.info);
  if (!frame) {
    result.message = frame.error();
    if (log_.allow(result.message)) ROS_WARN("relocalizer: unusable frame: %s", result.message.c_str());
    result.processing_time = std::chrono::duration<float>(Clock::now() - start).count();
    publishOutcome(result, nullptr, nullptr, std::nullopt, true);
    return result;
  }
  const std::shared_ptr<const relocalizer::Relocalizer> model = currentModel();
  if (!model) {
    const relocalizer::LearningStatus status = learner_->status();
    result.message = "no model yet: learning has " + std::to_string(status.keyframes_stored) +
                     " key frames, the first model needs " + std::to_string(params_.learn_first_retrain) +
                     (status.retraining ? " (being trained now)" : "") +
                     "; is SLAM publishing " + params_.map_frame + " -> camera on TF?";
    result.processing_time = std::chrono::duration<float>(Clock::now() - start).count();
    publishOutcome(result, nullptr, nullptr, std::nullopt, true);
    return result;
  }
  const relocalizer::Relocalization solved = model->relocalize(*frame);
  result.success = solved.success;
  result.message = solved.message;
  result.point_inliers = static_cast<uint32_t>(solved.point_inliers);
  result.line_inliers = static_cast<uint32_t>(solved.line_inliers);
  result.score = solved.score;
  result.surface_agreement = solved.surface_agreement;
  result.time_sampling = static_cast<float>(solved.timings.sampling);
  result.time_forest = static_cast<float>(solved.timings.forest);
  result.time_ransac = static_cast<float>(solved.timings.ransac);
  result.time_refinement = static_cast<float>(solved.timings.refinement);
  result.time_surface = static_cast<float>(solved.timings.surface);

  std::optional<geometry_msgs::TransformStamped> transform;
  if (solved.success && transforms_) {
    const std::string camera_frame = stripLeadingSlashes(input.colour->header.frame_id);
    auto prepared = transforms_->prepare(solved.pose, stamp, camera_frame);
    if (prepared) {
      transform = std::move(*prepared);
    } else {
      // The pose alone would leave TF consumers without the correction they
      // act on; report the attempt as failed rather than half-done.
      result.success = false;
      result.message = "relocalized, but " + prepared.error();
    }
  }
  if (!result.success && log_.allow(result.message)) {
    if (solved.success)  // TF trouble is a configuration fault, not a hard frame
      ROS_WARN("relocalizer: frame at %.3f: %s", stamp.toSec(), result.message.c_str());
    else
      ROS_INFO("relocalizer: no pose for the frame at %.3f: %s", stamp.toSec(), result.message.c_str());
  }
  result.processing_time = std::chrono::duration<float>(Clock::now() - start).count();
  publishOutcome(result, result.success ? &solved.pose : nullptr,
                 result.success ? &solved.covariance : nullptr, transform, true, input.epoch);
  return result;
}

void RelocalizerNode::publishOutcome(ResultMsg& result, const relocalizer::Pose* pose,
                                     const relocalizer::Matrix6d* covariance,
                                     const std::optional<geometry_msgs::TransformStamped>& transform,
                                     bool frame_attempt, uint64_t epoch) {
  if (frame_attempt && !result.success) ++frames_failed_;
  result.frames_received = saturate(frames_received_);
  result.frames_processed = saturate(frames_processed_);
  result.frames_dropped = params_.mode == Mode::Continuous ? saturate(frames_.dropped()) : 0;
  result.frames_failed = saturate(frames_failed_);
  result.time_jumps = saturate(time_jumps_);
  result.messages_dropped = saturate(messages_dropped_);
  if (learner_) {
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
  if (pose) {
    result.pose.header = result.header;
    result.pose.pose = toPoseWithCovarianceMsg(*pose, *covariance);
  }
  result_pub_.publish(result);
  if (!pose) return;
  pose_pub_.publish(result.pose);
  if (transform) transforms_->send(*transform, result.header.stamp, epoch);
}

RelocalizerNode::ResultMsg RelocalizerNode::processShared(uint64_t seq, const InputPtr& input) {
  std::promise<ResultMsg> promise;
  std::shared_future<ResultMsg> future;
  {
    std::lock_guard<std::mutex> lock(shared_mutex_);
    auto it = in_flight_.find(seq);
    if (it != in_flight_.end()) {
      future = it->second;
    } else {
      in_flight_.emplace(seq, promise.get_future().share());
    }
  }
  if (future.valid()) return future.get();
  ResultMsg result = process(*input);
  promise.set_value(result);
  std::lock_guard<std::mutex> lock(shared_mutex_);
  in_flight_.erase(seq);
  return result;
}

bool RelocalizerNode::onRelocalize(relocalizer::Relocalize::Request& request,
                                   relocalizer::Relocalize::Response& response) {
  ResultMsg result;
  if (std::isnan(request.timeout) || request.timeout == std::numeric_limits<double>::infinity()) {
    // NaN is no duration, and an endless wait would hold one of the few
    // service threads for good: both are refused at once.
    result = failure(ros::Time::now(), std::string("timeout must be a finite number of seconds (got ") +
                                           (std::isnan(request.timeout) ? "NaN" : "infinity") +
                                           "); 0 or less means ~service_timeout (" +
                                           seconds(params_.service_timeout) + " s)");
    if (log_.allow("service timeout"))
      ROS_WARN("relocalizer: %s: %s", service_.getService().c_str(), result.message.c_str());
    publishOutcome(result, nullptr, nullptr, std::nullopt, false);
  } else {
    const double asked = request.timeout > 0.0 ? request.timeout : params_.service_timeout;
    const double timeout = std::min(asked, kMaxServiceWaitSeconds);
    // The wait counts from the call's arrival: time spent queued behind other
    // calls is part of what the caller waited.
    const Clock::time_point arrival = ServiceCallQueue::callArrival();
    const auto deadline =
        arrival + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout));
    const double queued = std::chrono::duration<double>(Clock::now() - arrival).count();
    const uint64_t after = request.wait_for_next ? frames_.lastSeq() : 0;
    auto entry = frames_.newest(after, deadline);
    if (entry) {
      result = processShared(entry->seq, entry->value);
    } else {
      const std::string capped = asked > kMaxServiceWaitSeconds ? " (the longest wait a call can ask for; it asked " +
                                                                   seconds(asked) + " s)"
                                                             : "";
      const std::string behind = queued >= kQueuedReportSeconds
                                     ? ", " + seconds(queued) + " s of it queued behind other calls"
                                     : "";
      result = failure(ros::Time::now(), std::string(request.wait_for_next ? "no new" : "no") +
                                             " synchronised frame within " + seconds(timeout) + " s" + capped +
                                             behind + "; " + inputStatus());
      if (log_.allow("service without frame"))
        ROS_WARN("relocalizer: %s: %s", service_.getService().c_str(), result.message.c_str());
      publishOutcome(result, nullptr, nullptr, std::nullopt, false);
    }
  }
  response.success = result.success;
  response.message = result.message;
  response.pose = result.pose;
  response.point_inliers = result.point_inliers;
  response.line_inliers = result.line_inliers;
  response.score = result.score;
  response.surface_agreement = result.surface_agreement;
  response.processing_time = result.processing_time;
  // A failed relocalization is an answer, not a transport error: returning
  // false would hide the message from the caller.
  return true;
}

}  // namespace relocalizer_ros
