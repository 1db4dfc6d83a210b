#include "node_inputs.h"

#include "../conversion/message_conversion.h"
#include "node_text.h"

namespace relocalizer_ros {

namespace {

using Clock = std::chrono::steady_clock;

// Time jumps are logged one line each, at most this often (a source whose
// stamps jitter backwards on every frame must not flood the log).
constexpr std::chrono::seconds kJumpLogPeriod{1};

const char* const kInputNames[3] = {"colour", "depth", "camera_info"};

}  // namespace

NodeInputs::NodeInputs(ros::NodeHandle nh, ros::NodeHandle private_nh, const InputSettings& params,
                       const TfSettings& tf_settings, Handlers handlers)
    : nh_(std::move(nh)),
      params_(params),
      tf_settings_(tf_settings),
      handlers_(std::move(handlers)),
      start_ns_(steadyNanoseconds()) {
  image_transport_ = std::make_unique<image_transport::ImageTransport>(nh_);
  // Lets users pick compressed transports with ~image_transport, as image_proc does.
  const image_transport::TransportHints hints("raw", ros::TransportHints(), private_nh);
  const uint32_t queue = static_cast<uint32_t>(params_.sync_queue_size);
  colour_sub_.subscribe(*image_transport_, "rgb/image", queue, hints);
  depth_sub_.subscribe(*image_transport_, "depth/image", queue, hints);
  info_sub_.subscribe(nh_, "rgb/camera_info", queue);

  InputSynchronizer::Options options;
  options.approximate = params_.approx_sync;
  options.queue_size = static_cast<uint32_t>(params_.sync_queue_size);
  options.max_interval = params_.max_interval;
  InputSynchronizer::Events events;
  events.on_set =
      [this](const sensor_msgs::ImageConstPtr& colour, const sensor_msgs::ImageConstPtr& depth,
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
  if (params_.input_timeout > 0.0)
    watchdog_ = nh_.createWallTimer(ros::WallDuration(1.0), &NodeInputs::onWatchdog, this);
}

template <int I, typename M>
void NodeInputs::onInput(const boost::shared_ptr<M const>& message) {
  std::lock_guard<std::mutex> lock(input_mutex_);
  try {
    inputs_->add<I>(message, Clock::now());
  } catch (const std::exception& e) {
    // The stamp gate keeps message_filters' arithmetic in range (fuzz_stamps
    // checks it); should anything else throw, one message is lost, not the node.
    ++messages_dropped_;
    if (log_.allow("synchronizer error"))
      ROS_ERROR("relocalizer: dropped a message on %s: %s", topic(I).c_str(), e.what());
  }
}

std::string NodeInputs::topic(int input) const {
  return input == 0   ? colour_sub_.getTopic()
         : input == 1 ? depth_sub_.getTopic()
                      : info_sub_.getTopic();
}

void NodeInputs::onStampDropped(int input, StampGate::Drop why, int64_t stamp_ns) {
  ++messages_dropped_;
  const std::string stamp = stampText(stamp_ns);
  std::string text;
  switch (why) {
    case StampGate::Drop::BeyondRange:
      text = "stamped " + stamp +
             " s, at or past 2^31 s (the year 2038), where ROS time arithmetic "
             "overflows: an uninitialised driver stamp?";
      break;
    case StampGate::Drop::OutOfOrder:
      text = "stamped " + stamp +
             " s, before the previous message on it (out of order by less than " +
             secondsText(1e-9 * StampGate::kMinJumpNs) + " s, too little for a jump)";
      break;
    case StampGate::Drop::Unconfirmed:
      text = "stamped " + stamp +
             " s, off the other messages' timeline, and no later message "
             "followed it there: a glitch, not a jump";
      break;
    case StampGate::Drop::OldTimeline:  // expected after every jump: counted, not logged
    case StampGate::Drop::None:
      return;
  }
  const std::string key = "stamp drop " + std::to_string(static_cast<int>(why));
  if (log_.allow(key))
    ROS_WARN("relocalizer: dropped a %s message on %s %s", kInputNames[input], topic(input).c_str(),
             text.c_str());
}

void NodeInputs::onTimeJump(const StampGate::Jump& jump) {
  // The frames waiting to be relocalized are from the old timeline, and tf2
  // would refuse the new timeline's odom -> camera as older than what it holds.
  const uint64_t jumps = ++time_jumps_;
  const size_t dropped = handlers_.on_jump();

  const int64_t step = jump.to_ns - jump.from_ns;
  const std::string what =
      std::string(step < 0 ? "stamps went back in time by " : "stamps jumped forward by ") +
      secondsText(1e-9 * static_cast<double>(step < 0 ? -step : step)) + " s on " +
      topic(jump.input) + " (" + kInputNames[jump.input] + ", " + stampText(jump.to_ns) +
      " after " + stampText(jump.from_ns) + ")";
  const std::string done =
      std::string("; a looping bag or a restarted source? synchronizer reset, ") +
      std::to_string(dropped) + " pending frame" + (dropped == 1 ? "" : "s") + " dropped" +
      (tf_settings_.publish_tf && !tf_settings_.odom_frame.empty() ? ", TF buffer cleared" : "");
  const auto now = Clock::now();
  if (jumps == 1 || now - last_jump_log_ >= kJumpLogPeriod) {
    const std::string more = unlogged_jumps_ ? " (" + std::to_string(unlogged_jumps_) +
                                                   " more jumps since the last report)"
                                             : "";
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
    handlers_.on_report(stamp, what + "; synchronizer and frame buffer reset");
  }
}

void NodeInputs::onSynchronised(const sensor_msgs::ImageConstPtr& colour,
                                const sensor_msgs::ImageConstPtr& depth,
                                const sensor_msgs::CameraInfoConstPtr& info) {
  auto input = std::make_shared<FrameInput>();
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
  handlers_.on_frame(std::move(input));
}

NodeInputs::~NodeInputs() { stop(); }

void NodeInputs::stop() {
  watchdog_.stop();
  colour_sub_.unsubscribe();
  depth_sub_.unsubscribe();
  info_sub_.unsubscribe();
}

std::string NodeInputs::topics() const {
  return colour_sub_.getTopic() + ", " + depth_sub_.getTopic() + ", " + info_sub_.getTopic();
}

void NodeInputs::onWatchdog(const ros::WallTimerEvent&) {
  const int64_t now = steadyNanoseconds();
  const double timeout = params_.input_timeout;
  const double since_image = secondsSince(last_image_ns_, now);
  const double since_frame = secondsSince(last_frame_ns_, now);
  if (since_image < timeout && since_frame >= timeout) {
    // Images flow but never form a set: a missing camera_info, or stamps that
    // never match. Nothing else would ever report it, so the watchdog does.
    const std::string why = "images arrive but no synchronised frame for " +
                            secondsText(since_frame) + " s; " + status();
    if (log_.allow("unsynchronised")) ROS_WARN("relocalizer: %s", why.c_str());
    if (params_.mode == Mode::Continuous) {
      ros::Time stamp;
      {
        std::lock_guard<std::mutex> lock(stamp_mutex_);
        stamp = last_image_stamp_;
      }
      handlers_.on_report(stamp, why);
    }
  } else if (since_image >= timeout && since_frame >= timeout && log_.allow("no input")) {
    ROS_WARN("relocalizer: no image for %s s on %s or %s", secondsText(since_image).c_str(),
             colour_sub_.getTopic().c_str(), depth_sub_.getTopic().c_str());
  }
}

double NodeInputs::secondsSince(int64_t last_ns, int64_t now_ns) const {
  return 1e-9 * static_cast<double>(now_ns - (last_ns ? last_ns : start_ns_));
}

NodeInputs::Activity NodeInputs::activity() const {
  Activity activity;
  for (int input = 0; input < 3; ++input) activity.topics[input] = topic(input);
  activity.messages = {colour_count_, depth_count_, info_count_};
  const int64_t last_frame = last_frame_ns_;
  activity.any_frame = last_frame != 0;
  activity.since_frame = secondsSince(last_frame, steadyNanoseconds());
  return activity;
}

std::string NodeInputs::status() const {
  const uint64_t colour = colour_count_ - colour_at_sync_;
  const uint64_t depth = depth_count_ - depth_at_sync_;
  const uint64_t info = info_count_ - info_at_sync_;
  const uint64_t sets = frames_received_;
  std::string status =
      "received " + std::to_string(colour) + " on " + colour_sub_.getTopic() + ", " +
      std::to_string(depth) + " on " + depth_sub_.getTopic() + ", " + std::to_string(info) +
      " on " + info_sub_.getTopic() +
      (sets ? " since the last synchronised frame" : " and no synchronised frame yet");
  if (colour == 0 || depth == 0 || info == 0) {
    status += "; is every topic published?";
  } else {
    status += params_.approx_sync ? "; do the stamps differ by more than max_interval (" +
                                        secondsText(params_.max_interval) + " s)?"
                                  : "; approx_sync is false but the stamps differ";
  }
  return status;
}

}  // namespace relocalizer_ros
