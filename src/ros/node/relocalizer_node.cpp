#include "relocalizer_node.h"

#include <new>

#include "../conversion/message_conversion.h"
#include "node_text.h"

namespace relocalizer_ros {

namespace {

using Clock = std::chrono::steady_clock;

// Service calls that can wait or compute at once; further ones queue, and
// their wait counts from their arrival. Far more than any SLAM stack makes.
constexpr size_t kServiceThreads = 64;
// A process_all backlog this long means the source outruns the node: the
// replay player paces itself, rosbag play does not.
constexpr size_t kBacklogWarning = 30;
constexpr const char* kNoPlace = "no place loaded (load one with ~load_place)";

// The learned place's name, "" outside learn mode: the parts that tell its
// submaps from other places (isLearnedPlaceName, place_settings.h).
std::string learnedPlace(const NodeParams& params) {
  return params.learn ? placeName(params, true) : "";
}

}  // namespace

relocalizer::Expected<std::unique_ptr<RelocalizerNode>> RelocalizerNode::create(
    ros::NodeHandle nh, ros::NodeHandle private_nh) {
  auto params = loadNodeParams(private_nh);
  if (!params) return relocalizer::makeError(params.error());
  std::unique_ptr<relocalizer::SubmapLearner> learner;
  NodePlaces::LearnedModels learned;
  if (params->learn) {
    auto made = LearningFeed::makeLearner(
        *params, params->model, {learnedPlace(*params), params->map_frame}, params->relocalizer);
    if (!made) return relocalizer::makeError(made.error());
    learner = std::move(*made);
    // The learner lives as long as the node, and the places only ask while it runs.
    learned = [submaps = learner.get()] { return submaps->models(); };
  }
  auto places = NodePlaces::create(*params, *params, params->relocalizer, std::move(learned));
  if (!places) return relocalizer::makeError(places.error());
  return std::unique_ptr<RelocalizerNode>(
      new RelocalizerNode(std::move(nh), std::move(private_nh), std::move(*params),
                          std::move(*places), std::move(learner)));
}

RelocalizerNode::RelocalizerNode(ros::NodeHandle nh, ros::NodeHandle private_nh, NodeParams params,
                                 std::unique_ptr<NodePlaces> places,
                                 std::unique_ptr<relocalizer::SubmapLearner> learner)
    : nh_(std::move(nh)),
      private_nh_(std::move(private_nh)),
      params_(std::move(params)),
      thread_limit_(params_.threads > 0 ? std::make_unique<tbb::global_control>(
                                              tbb::global_control::max_allowed_parallelism,
                                              static_cast<size_t>(params_.threads))
                                        : nullptr),
      places_(std::move(places)),
      tf_listener_(tf_, nh_, true),
      frames_(params_.mode == Mode::Continuous && params_.process_all
                  ? FrameBuffer<FrameInputPtr>::Policy::Fifo
                  : FrameBuffer<FrameInputPtr>::Policy::Latest),
      output_(
          nh_, private_nh_, params_, learnedPlace(params_),
          [this](ResultMsg& result) { fillCounters(result); }, tf_),
      service_calls_(kServiceThreads) {
  NodeDiagnostics::Sources watched;
  watched.places = places_.get();
  watched.no_place = [this] { return noPlaceReason(); };
  watched.counters = [this](ResultMsg& result) { fillCounters(result); };
  watched.inputs = [this] { return inputs_ ? inputs_->activity() : NodeInputs::Activity{}; };
  diagnostics_ = std::make_unique<NodeDiagnostics>(nh_, private_nh_, params_, params_,
                                                   std::move(watched), output_);

  visuals_ = std::make_unique<NodeVisuals>(private_nh_, params_.map_frame,
                                           [this] { return places_->places(); });
  output_.addListener([this](const NodeOutput::Published& p) { visuals_->onPublished(p); });
  places_->onChange([this] { visuals_->placesChanged(); });
  visuals_->placesChanged();
  if (PoseHandoff::wanted(params_)) {
    handoff_ = std::make_unique<PoseHandoff>(nh_, params_, params_.tf_timeout, tf_);
    output_.addListener(
        [handoff = handoff_.get()](const NodeOutput::Published& p) { handoff->onPublished(p); });
  }
  RelocalizeService::Sources sources;
  sources.frames = &frames_;
  hints_ = std::make_unique<NodeHints>(nh_, params_, tf_, [this] {
    std::vector<std::string> frames;
    for (const relocalizer::PlaceFigures& place : places_->list())
      frames.push_back(place.map_frame);
    if (frames.empty()) frames.push_back(params_.map_frame);
    return frames;
  });
  sources.process = [this](const FrameInput& input, const relocalizer::PoseHint* hint) {
    return process(input, hint);
  };
  sources.read_hint = [this](const NodeHints::HintMsg& msg) { return hints_->read(msg); };
  sources.input_status = [this] {
    return inputs_ ? inputs_->status() : std::string("no input yet");
  };
  sources.output = &output_;
  service_ =
      std::make_unique<RelocalizeService>(private_nh_, params_, std::move(sources), service_calls_);
  if (learner)
    learning_ = std::make_unique<LearningFeed>(private_nh_, params_, params_, tf_,
                                               std::move(learner), service_calls_);
  places_->advertise(private_nh_, service_calls_);
  if (params_.mode == Mode::Continuous) worker_ = std::thread(&RelocalizerNode::workerLoop, this);

  NodeInputs::Handlers handlers;
  handlers.on_frame = [this](FrameInputPtr input) { onFrame(std::move(input)); };
  handlers.on_jump = [this] {
    output_.resetTransforms();
    return frames_.clear();
  };
  handlers.on_report = [this](const ros::Time& stamp, const std::string& what) {
    ResultMsg result = output_.failure(stamp, what);
    output_.report(result);
  };
  inputs_ = std::make_unique<NodeInputs>(nh_, private_nh_, params_, params_, std::move(handlers));
  diagnostics_->start();
  logStartup();
}

void RelocalizerNode::logStartup() const {
  std::string model_text;
  for (const relocalizer::PlaceFigures& place : places_->list())
    model_text += (model_text.empty() ? "" : ", ") + placeText(place);
  model_text = model_text.empty() ? "no place yet" : "places " + model_text;
  if (learning_) {
    const relocalizer::SubmapStatus status = learning_->status();
    model_text +=
        std::string(", learning place '") + learnedPlace(params_) + "' from TF " +
        params_.map_frame + " -> camera (" + std::to_string(status.keyframes_added) +
        " key frames so far, key frames at " +
        relocalizer::formatMinMotion(params_.learning.min_motion) + " m,deg" +
        (params_.save_on_exit.empty() ? "" : ", saved to " + params_.save_on_exit + " on exit") +
        ")";
  }
  const std::string tf_text = !params_.publish_tf ? "no TF"
                              : params_.odom_frame.empty()
                                  ? "place frame -> camera TF"
                                  : "place frame -> " + params_.odom_frame + " TF";
  const std::string mode_text =
      params_.mode == Mode::OnDemand
          ? "on demand (call " + service_->name() + ")"
          : std::string("continuous") +
                (params_.max_rate > 0 ? " at up to " + secondsText(params_.max_rate) + " Hz" : "") +
                (params_.process_all ? ", every frame" : "");
  ROS_INFO("relocalizer: %s, %s, %s; frames from %s", model_text.c_str(), mode_text.c_str(),
           tf_text.c_str(), inputs_->topics().c_str());
}

RelocalizerNode::~RelocalizerNode() {
  // No input callback may run past this point (roscpp waits for one in
  // progress): they feed the frame buffers. Diagnostics read the inputs.
  diagnostics_->stop();
  if (inputs_) inputs_->stop();
  // Wake every waiter first, so neither the worker nor a service call blocks
  // the joins below.
  frames_.close();
  if (learning_) learning_->close();
  service_->shutdown();
  places_->shutdown();
  service_calls_.stop();
  if (worker_.joinable()) worker_.join();
  // learning_'s destructor joins its thread and writes save_on_exit.
}

void RelocalizerNode::onFrame(FrameInputPtr input) {
  if (learning_) learning_->push(input);
  frames_.push(std::move(input));
  if (params_.process_all && params_.mode == Mode::Continuous &&
      frames_.pendingCount() > kBacklogWarning && log_.allow("backlog"))
    ROS_WARN(
        "relocalizer: %zu frames wait to be relocalized (process_all): the source is faster "
        "than the node, and latency grows; pace it (replay.launch does) or slow it down",
        frames_.pendingCount());
}

void RelocalizerNode::fillCounters(ResultMsg& result) const {
  result.frames_received = saturate(inputs_ ? inputs_->framesReceived() : 0);
  result.frames_processed = saturate(frames_processed_);
  result.frames_dropped = params_.mode == Mode::Continuous ? saturate(frames_.dropped()) : 0;
  result.frames_failed = saturate(output_.framesFailed());
  result.time_jumps = saturate(inputs_ ? inputs_->timeJumps() : 0);
  result.messages_dropped = saturate(inputs_ ? inputs_->messagesDropped() : 0);
  if (learning_) learning_->fill(result);
}

std::string RelocalizerNode::noPlaceReason() const {
  return learning_ ? learning_->noModelYet() : kNoPlace;
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

RelocalizerNode::ResultMsg RelocalizerNode::process(const FrameInput& input,
                                                    const relocalizer::PoseHint* hint) {
  const auto start = Clock::now();
  const ros::Time stamp = input.colour->header.stamp;
  ++frames_processed_;
  ResultMsg result = output_.failure(stamp, input.error);
  if (!input.error.empty()) {
    // Already logged when it arrived.
    output_.frameFailed(result, &input);
    return result;
  }
  try {
    return processChecked(input, start, hint);
  } catch (const std::exception& e) {
    // A frame the core chokes on must cost one failure result, not the node
    // (or, through an unset promise, every waiting service call).
    // The answer says it in our words; the library's text is for the log.
    result.message =
        dynamic_cast<const std::bad_alloc*>(&e)
            ? "internal error: out of memory while relocalizing this frame"
            : "internal error while relocalizing this frame (the node's log says more)";
    ROS_ERROR("relocalizer: frame at %.3f: %s: %s", stamp.toSec(), result.message.c_str(),
              messageExcerpt(e.what(), 256).c_str());
    result.processing_time = std::chrono::duration<float>(Clock::now() - start).count();
    output_.frameFailed(result, &input);
    return result;
  }
}

RelocalizerNode::ResultMsg RelocalizerNode::processChecked(const FrameInput& input,
                                                           Clock::time_point start,
                                                           const relocalizer::PoseHint* hint) {
  const ros::Time stamp = input.colour->header.stamp;
  auto frame = frameFromMessages(*input.colour, *input.depth, *input.info);
  const bool no_place = frame && places_->empty();
  if (!frame || no_place) {
    ResultMsg result = output_.failure(stamp, frame ? noPlaceReason() : frame.error());
    if (!frame && log_.allow(result.message))
      ROS_WARN("relocalizer: unusable frame: %s", result.message.c_str());
    result.processing_time = std::chrono::duration<float>(Clock::now() - start).count();
    output_.frameFailed(result, &input);
    return result;
  }
  const auto relocalize = [&](const relocalizer::PoseHint* used) {
    return places_->relocalize(*frame, used);
  };
  return output_.answer(input, hints_->relocalize(relocalize, hint), start);
}

}  // namespace relocalizer_ros
