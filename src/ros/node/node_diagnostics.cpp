#include "node_diagnostics.h"

#include <diagnostic_msgs/DiagnosticStatus.h>

#include <algorithm>

#include "node_text.h"

namespace relocalizer_ros {

namespace {

using diagnostic_updater::DiagnosticStatusWrapper;

constexpr const char* kNodeTask = "relocalization";
constexpr const char* kPlaceTaskPrefix = "place ";
constexpr const char* kNever = "none yet";
// The input rates span this much time (once the node has run this long): one
// diagnostic_period would make them jump by a frame's worth at every status.
constexpr int64_t kRateWindowNs = 5'000'000'000;

// diagnostic_updater announces every task it is given as "Node starting up"
// (OK): a place loaded at run time is not starting up, and a node without a
// usable place must not look OK until its first real status.
class QuietUpdater : public diagnostic_updater::Updater {
 public:
  using Updater::Updater;

 private:
  void addedTaskCallback(DiagnosticTaskInternal&) override {}
};

unsigned char statusLevel(HealthLevel level) {
  switch (level) {
    case HealthLevel::Ok:
      return diagnostic_msgs::DiagnosticStatus::OK;
    case HealthLevel::Warn:
      return diagnostic_msgs::DiagnosticStatus::WARN;
    case HealthLevel::Error:
      break;
  }
  return diagnostic_msgs::DiagnosticStatus::ERROR;
}

double secondsBetween(int64_t from_ns, int64_t to_ns) {
  return 1e-9 * static_cast<double>(to_ns - from_ns);
}

// The age of a moment on the steady clock (0: never).
std::string ageText(int64_t then_ns, int64_t now_ns) {
  return then_ns ? secondsText(secondsBetween(then_ns, now_ns)) : kNever;
}

void addLearning(DiagnosticStatusWrapper& status, const NodeOutput::ResultMsg& counters) {
  status.add("submaps", counters.submaps);
  status.add("key frames stored", counters.keyframes_stored);
  status.add("key frames learned", counters.keyframes_learned);
  status.add("learning backlog", counters.learning_backlog);
  status.add("frames untracked", counters.frames_untracked);
  status.add("SLAM poses refused", counters.slam_poses_refused);
  status.add("learning stopped", counters.learning_stopped ? "yes: SLAM's map moved" : "no");
  status.add("learning error", counters.learning_error.empty() ? "none" : counters.learning_error);
}

void addCounters(DiagnosticStatusWrapper& status, const NodeOutput::ResultMsg& counters) {
  status.add("frames received", counters.frames_received);
  status.add("frames processed", counters.frames_processed);
  status.add("frames failed", counters.frames_failed);
  status.add("frames dropped", counters.frames_dropped);
  status.add("time jumps", counters.time_jumps);
  status.add("messages dropped", counters.messages_dropped);
}

}  // namespace

NodeDiagnostics::NodeDiagnostics(ros::NodeHandle nh, ros::NodeHandle private_nh,
                                 const InputSettings& inputs, const DiagnosticSettings& settings,
                                 Sources sources, NodeOutput& output)
    : settings_(settings),
      mode_(inputs.mode),
      sources_(std::move(sources)),
      limits_{inputs.input_timeout, settings.diagnostics_max_failures},
      nh_(std::move(nh)) {
  // Named after the node itself, not the process: a nodelet's process is its manager.
  const std::string node = private_nh.getNamespace();
  updater_ = std::make_unique<QuietUpdater>(nh_, private_nh, node);
  updater_->setHardwareID("relocalizer: " + node);
  updater_->add(kNodeTask, [this](DiagnosticStatusWrapper& status) { nodeStatus(status); });
  output.addListener([this](const NodeOutput::Published& published) { onPublished(published); });
}

void NodeDiagnostics::start() {
  rate_samples_.push_back({steadyNanoseconds(), {}});
  update();
  timer_ = nh_.createWallTimer(ros::WallDuration(settings_.diagnostic_period),
                               [this](const ros::WallTimerEvent&) { update(); });
}

void NodeDiagnostics::onPublished(const NodeOutput::Published& published) {
  const NodeOutput::ResultMsg& result = published.result;
  const int64_t now = steadyNanoseconds();
  std::lock_guard<std::mutex> lock(mutex_);
  if (published.found) {
    for (const relocalizer::PlaceAttempt& attempt : published.found->attempts) {
      PlaceTally& tally = tallies_[attempt.place];
      ++tally.screened;
      tally.solved += attempt.solved;
    }
  }
  if (result.success) {
    failures_in_a_row_ = 0;
    last_pose_ns_ = now;
    last_place_ = result.place;
    PlaceTally& tally = tallies_[result.place];
    ++tally.answers;
    tally.last_answer_ns = now;
    return;
  }
  last_failure_ = result.message;
  last_failure_ns_ = now;
  // A report that is no frame's (a time jump, a call without a frame) says
  // why, but no frame failed: stopped inputs have their own rule.
  if (published.input) ++failures_in_a_row_;
}

void NodeDiagnostics::update() {
  places_ = sources_.places->list();
  followPlaces();
  updater_->force_update();
}

void NodeDiagnostics::followPlaces() {
  std::vector<std::string> names;
  if (places_.size() > 1)
    for (const relocalizer::PlaceFigures& place : places_) names.push_back(place.name);
  for (const std::string& name : place_tasks_)
    if (std::find(names.begin(), names.end(), name) == names.end())
      updater_->removeByName(kPlaceTaskPrefix + name);
  for (const std::string& name : names)
    if (std::find(place_tasks_.begin(), place_tasks_.end(), name) == place_tasks_.end())
      updater_->add(kPlaceTaskPrefix + name,
                    [this, name](DiagnosticStatusWrapper& status) { placeStatus(name, status); });
  place_tasks_ = std::move(names);
  // An unloaded place's answers are not a reloaded one's.
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = tallies_.begin(); it != tallies_.end();) {
    const bool loaded = std::any_of(
        places_.begin(), places_.end(),
        [&](const relocalizer::PlaceFigures& place) { return place.name == it->first; });
    it = loaded ? std::next(it) : tallies_.erase(it);
  }
}

void NodeDiagnostics::nodeStatus(DiagnosticStatusWrapper& status) {
  const int64_t now = steadyNanoseconds();
  NodeOutput::ResultMsg counters;
  sources_.counters(counters);
  const NodeInputs::Activity inputs = sources_.inputs();

  NodeHealth health;
  health.usable = !places_.empty();
  if (!health.usable) health.unusable_reason = sources_.no_place();
  health.any_frame = inputs.any_frame;
  health.since_frame = inputs.since_frame;
  int64_t last_failure_ns = 0;
  std::string last_place;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    health.failures_in_a_row = failures_in_a_row_;
    health.last_failure = last_failure_;
    health.since_pose = last_pose_ns_ ? secondsBetween(last_pose_ns_, now) : -1.0;
    last_failure_ns = last_failure_ns_;
    last_place = last_place_;
  }
  const HealthVerdict verdict = judgeHealth(health, limits_);
  status.summary(statusLevel(verdict.level), verdict.message);
  if (counters.learning && counters.learning_stopped)
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN,
                        "learning stopped: SLAM's map moved (see learning error)");

  std::string places;
  for (const relocalizer::PlaceFigures& place : places_)
    places += (places.empty() ? "" : ", ") + place.name + " (" + place.map_frame + ")";
  status.add("mode", modeName(mode_));
  status.add("places", places.empty() ? "none" : places);
  if (counters.learning) addLearning(status, counters);
  addInputs(status, inputs, now);
  status.add("last pose age (s)",
             health.since_pose < 0.0 ? std::string(kNever) : secondsText(health.since_pose));
  status.add("last pose place", last_place.empty() ? kNever : last_place);
  status.add("failures in a row", health.failures_in_a_row);
  status.add("last failure", health.last_failure.empty() ? "none" : health.last_failure);
  status.add("last failure age (s)", ageText(last_failure_ns, now));
  addCounters(status, counters);
}

void NodeDiagnostics::addInputs(DiagnosticStatusWrapper& status, const NodeInputs::Activity& inputs,
                                int64_t now_ns) {
  while (rate_samples_.size() > 1 && now_ns - rate_samples_[1].ns >= kRateWindowNs)
    rate_samples_.pop_front();
  const CountSample& since = rate_samples_.front();
  const double span = secondsBetween(since.ns, now_ns);
  for (size_t i = 0; i < inputs.topics.size(); ++i) {
    const uint64_t arrived = inputs.messages[i] - since.messages[i];
    status.add("input rate " + inputs.topics[i] + " (Hz)",
               secondsText(span > 0.0 ? static_cast<double>(arrived) / span : 0.0));
  }
  rate_samples_.push_back({now_ns, inputs.messages});
  status.add("last frame age (s)", inputs.any_frame ? secondsText(inputs.since_frame) : kNever);
}

void NodeDiagnostics::placeStatus(const std::string& name, DiagnosticStatusWrapper& status) {
  const int64_t now = steadyNanoseconds();
  const auto place =
      std::find_if(places_.begin(), places_.end(),
                   [&](const relocalizer::PlaceFigures& figures) { return figures.name == name; });
  if (place == places_.end()) {  // unloaded since this update's listing
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "unloaded");
    return;
  }
  PlaceTally tally;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = tallies_.find(name); it != tallies_.end()) tally = it->second;
  }
  status.summary(diagnostic_msgs::DiagnosticStatus::OK,
                 tally.answers ? std::to_string(tally.answers) + " poses, the last " +
                                     ageText(tally.last_answer_ns, now) + " s ago"
                               : "loaded, no pose from it yet");
  status.add("map frame", place->map_frame);
  status.add("model", place->source.empty() ? "learned" : place->source);
  status.add("point trees", place->point_trees);
  status.add("line trees", place->line_trees);
  status.add("modes", place->modes);
  status.add("surface voxels", place->surface_voxels);
  status.add("training frames", place->training_frames);
  status.add("model bytes", place->model_bytes);
  status.add("frames screened", tally.screened);
  status.add("frames solved", tally.solved);
  status.add("poses", tally.answers);
  status.add("last pose age (s)", ageText(tally.last_answer_ns, now));
}

}  // namespace relocalizer_ros
