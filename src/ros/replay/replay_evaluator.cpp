#include "replay_evaluator.h"

#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "../conversion/message_conversion.h"
#include "relocalizer/core/progress.h"
#include "relocalizer/core/statistics.h"
#include "relocalizer/core/version.h"

namespace relocalizer_ros {

// The messages of one bag time: a frame when colour, depth and camera_info share a stamp.
struct ReplayEvaluator::FrameGroup {
  ros::Time time;
  sensor_msgs::Image::ConstPtr colour;
  sensor_msgs::Image::ConstPtr depth;
  sensor_msgs::CameraInfo::ConstPtr info;
  geometry_msgs::PoseStamped::ConstPtr truth;
};

ReplayEvaluator::ReplayEvaluator(ros::NodeHandle nh, Options options)
    : nh_(std::move(nh)), options_(std::move(options)) {
  // Answers arrive on the global queue, served by run()'s spinner while the
  // main thread plays and waits.
  result_sub_ = nh_.subscribe("result", 100, &ReplayEvaluator::onResult, this);
}

void ReplayEvaluator::onResult(const ResultMsg::ConstPtr& result) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_message_ = ros::WallTime::now();
    if (results_.emplace(result->header.stamp, *result).second)
      answered_at_.emplace(result->header.stamp, last_message_);
  }
  result_arrived_.notify_all();
}

void ReplayEvaluator::onTruth(const geometry_msgs::PoseStamped::ConstPtr& truth) {
  std::lock_guard<std::mutex> lock(mutex_);
  collected_truths_.push_back(
      {static_cast<int>(truth->header.seq), truth->header.stamp, fromPoseMsg(truth->pose)});
  last_message_ = ros::WallTime::now();
}

int ReplayEvaluator::run() {
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const int code = options_.play ? play() : collect();
  spinner.stop();
  return code;
}

int ReplayEvaluator::play() {
  rosbag::Bag bag;
  try {
    bag.open(options_.bag, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    ROS_FATAL("replay: %s: %s", options_.bag.c_str(), e.what());
    return 2;
  }
  const FramePublishers publishers{
      nh_.advertise<sensor_msgs::Image>(options_.colour_topic, 5),
      nh_.advertise<sensor_msgs::Image>(options_.depth_topic, 5),
      nh_.advertise<sensor_msgs::CameraInfo>(options_.info_topic, 5),
      nh_.advertise<geometry_msgs::PoseStamped>(options_.truth_topic, 5)};
  if (!waitForNode(publishers)) return 1;

  std::vector<Truth> truths;
  PlayCounts counts;
  try {
    if (!playFrames(bag, publishers, truths, counts)) return 1;
    if (options_.rate > 0.0) waitForLastAnswers(counts);
  } catch (const rosbag::BagException& e) {
    ROS_FATAL("replay: %s: %s", options_.bag.c_str(), e.what());
    return 2;
  }
  if (counts.incomplete)
    ROS_WARN(
        "replay: skipped %d frames whose colour, depth and camera_info do not share one stamp "
        "(a make_bag bag has none; play other bags with rosbag play and collect mode)",
        counts.incomplete);
  if (counts.published == 0) {
    ROS_FATAL("replay: %s has no complete frame on %s, %s and %s", options_.bag.c_str(),
              options_.colour_topic.c_str(), options_.depth_topic.c_str(),
              options_.info_topic.c_str());
    return 2;
  }
  std::printf("replayed %d frames of %s through %s (%d without an answer)\n", counts.published,
              options_.bag.c_str(), result_sub_.getTopic().c_str(), counts.unanswered);
  if (options_.rate > 0.0) reportLatency(counts.published);
  return report(truths);
}

bool ReplayEvaluator::waitForNode(const FramePublishers& publishers) {
  // Publishing before the node listens would lose frames, and waiting for an
  // answer before ours is connected would lose answers.
  const ros::Publisher& colour_pub = publishers.colour;
  const ros::Publisher& depth_pub = publishers.depth;
  const ros::Publisher& info_pub = publishers.info;
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(options_.node_timeout);
  while (ros::ok() && (colour_pub.getNumSubscribers() == 0 || depth_pub.getNumSubscribers() == 0 ||
                       info_pub.getNumSubscribers() == 0 || result_sub_.getNumPublishers() == 0)) {
    if (ros::WallTime::now() > give_up) {
      ROS_FATAL("replay: no relocalizer listens on %s, %s and %s and publishes %s after %.0f s",
                colour_pub.getTopic().c_str(), depth_pub.getTopic().c_str(),
                info_pub.getTopic().c_str(), result_sub_.getTopic().c_str(), options_.node_timeout);
      return false;
    }
    ros::WallDuration(0.05).sleep();
  }
  return true;
}

bool ReplayEvaluator::playFrames(rosbag::Bag& bag, const FramePublishers& publishers,
                                 std::vector<Truth>& truths, PlayCounts& counts) {
  const std::vector<std::string> topics = {options_.colour_topic, options_.depth_topic,
                                           options_.info_topic, options_.truth_topic,
                                           options_.dataset_topic};
  rosbag::View frames_view(bag, rosbag::TopicQuery(options_.colour_topic));
  relocalizer::ProgressBar bar("replaying", frames_view.size());
  rosbag::View view(bag, rosbag::TopicQuery(topics));
  FrameGroup group;
  ros::WallTime next_slot = ros::WallTime::now();
  for (const rosbag::MessageInstance& message : view) {
    if (message.getTopic() == options_.dataset_topic) {
      if (auto info = message.instantiate<std_msgs::String>()) {
        dataset_info_ = nlohmann::json::parse(info->data, nullptr, false);
        if (dataset_info_.is_discarded()) dataset_info_ = nullptr;
      }
      continue;
    }
    if (message.getTime() != group.time &&
        !publishFrame(group, publishers, bar, next_slot, truths, counts))
      return false;
    group.time = message.getTime();
    if (message.getTopic() == options_.colour_topic) {
      group.colour = message.instantiate<sensor_msgs::Image>();
    } else if (message.getTopic() == options_.depth_topic) {
      group.depth = message.instantiate<sensor_msgs::Image>();
    } else if (message.getTopic() == options_.info_topic) {
      group.info = message.instantiate<sensor_msgs::CameraInfo>();
    } else if (message.getTopic() == options_.truth_topic) {
      group.truth = message.instantiate<geometry_msgs::PoseStamped>();
    }
  }
  return publishFrame(group, publishers, bar, next_slot, truths, counts);
}

bool ReplayEvaluator::publishFrame(FrameGroup& group, const FramePublishers& publishers,
                                   relocalizer::ProgressBar& bar, ros::WallTime& next_slot,
                                   std::vector<Truth>& truths, PlayCounts& counts) {
  if (!group.colour && !group.depth && !group.info) return true;
  if (!group.colour || !group.depth || !group.info ||
      group.colour->header.stamp != group.depth->header.stamp ||
      group.colour->header.stamp != group.info->header.stamp) {
    ++counts.incomplete;
    group = {};
    return true;
  }
  const ros::Time stamp = group.colour->header.stamp;
  if (group.truth) {
    publishers.truth.publish(group.truth);
    truths.push_back({static_cast<int>(group.truth->header.seq), group.truth->header.stamp,
                      fromPoseMsg(group.truth->pose)});
  }
  publishers.info.publish(group.info);
  publishers.depth.publish(group.depth);
  publishers.colour.publish(group.colour);
  ++counts.published;
  bar.advance();
  if (options_.rate > 0.0) {
    // A camera does not wait for the node: the next frame goes out on
    // schedule (late frames go at once, so the mean rate holds).
    {
      std::lock_guard<std::mutex> lock(mutex_);
      published_at_[stamp] = ros::WallTime::now();
    }
    next_slot += ros::WallDuration(1.0 / options_.rate);
    const ros::WallDuration wait = next_slot - ros::WallTime::now();
    if (wait > ros::WallDuration(0)) wait.sleep();
    if (!ros::ok()) return false;
    group = {};
    return true;
  }
  std::unique_lock<std::mutex> lock(mutex_);
  const bool answered =
      result_arrived_.wait_for(lock, std::chrono::duration<double>(options_.result_timeout),
                               [&] { return results_.count(stamp) > 0 || !ros::ok(); });
  if (!ros::ok()) return false;
  if (!answered) {
    ++counts.unanswered;
    ROS_WARN("replay: no result for the frame at %.3f within %.0f s; going on", stamp.toSec(),
             options_.result_timeout);
  }
  group = {};
  return true;
}

void ReplayEvaluator::waitForLastAnswers(PlayCounts& counts) {
  // The last frames' answers are still on their way; wait for the node
  // to finish what it took (it drops what it did not).
  const auto idle = std::chrono::duration<double>(std::min(options_.result_timeout, 5.0));
  std::unique_lock<std::mutex> lock(mutex_);
  while (ros::ok()) {
    const size_t before = results_.size();
    result_arrived_.wait_for(lock, idle);
    if (results_.size() == before) break;
  }
  for (const auto& sent : published_at_) counts.unanswered += results_.count(sent.first) == 0;
}

void ReplayEvaluator::reportLatency(int published) {
  std::vector<double> latencies_ms;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [stamp, sent] : published_at_) {
      const auto answer = answered_at_.find(stamp);
      if (answer != answered_at_.end())
        latencies_ms.push_back((answer->second - sent).toSec() * 1e3);
    }
  }
  const double median_ms = relocalizer::median(latencies_ms);
  const double p95_ms = relocalizer::percentile(latencies_ms, 95.0);
  const double max_ms = latencies_ms.empty()
                            ? std::nan("")
                            : *std::max_element(latencies_ms.begin(), latencies_ms.end());
  const double share = published > 0 ? static_cast<double>(latencies_ms.size()) / published : 0.0;
  std::printf(
      "paced at %.1f Hz: %zu of %d frames answered (%.1f %%); latency from publish to ~result: "
      "median %.1f ms, 95th percentile %.1f ms, max %.1f ms\n",
      options_.rate, latencies_ms.size(), published, 100.0 * share, median_ms, p95_ms, max_ms);
  if (options_.output.empty()) return;
  nlohmann::json out;
  out["rate_hz"] = options_.rate;
  out["published"] = published;
  out["answered"] = latencies_ms.size();
  out["answered_share"] = share;
  if (!latencies_ms.empty()) {
    out["latency_ms_median"] = median_ms;
    out["latency_ms_p95"] = p95_ms;
    out["latency_ms_max"] = max_ms;
  }
  std::filesystem::create_directories(options_.output);
  std::ofstream(options_.output + "/latency.json") << out.dump(2) << "\n";
}

int ReplayEvaluator::collect() {
  ros::Subscriber truth_sub =
      nh_.subscribe(options_.truth_topic, 100, &ReplayEvaluator::onTruth, this);
  ros::Subscriber info_sub = nh_.subscribe<std_msgs::String>(
      options_.dataset_topic, 1, [this](const std_msgs::String::ConstPtr& info) {
        std::lock_guard<std::mutex> lock(mutex_);
        dataset_info_ = nlohmann::json::parse(info->data, nullptr, false);
        if (dataset_info_.is_discarded()) dataset_info_ = nullptr;
      });
  std::printf("collecting %s and %s until %.0f s pass without either (or Ctrl-C)\n",
              result_sub_.getTopic().c_str(), truth_sub.getTopic().c_str(), options_.idle_timeout);
  while (ros::ok()) {
    ros::WallDuration(0.2).sleep();
    std::lock_guard<std::mutex> lock(mutex_);
    if (!last_message_.isZero() &&
        (ros::WallTime::now() - last_message_).toSec() > options_.idle_timeout)
      break;
  }
  std::vector<Truth> truths;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    truths = collected_truths_;
  }
  std::sort(truths.begin(), truths.end(),
            [](const Truth& a, const Truth& b) { return a.stamp < b.stamp; });
  return report(truths);
}

int ReplayEvaluator::report(const std::vector<Truth>& truths) {
  std::lock_guard<std::mutex> lock(mutex_);
  const bool integer_stamps =
      dataset_info_.is_object() && dataset_info_.value("integer_stamps", false);
  std::vector<relocalizer::EvaluationRecord> records;
  int without_result = 0;
  uint32_t received = 0, processed = 0, dropped = 0;
  for (const Truth& truth : truths) {
    auto it = results_.find(truth.stamp);
    if (it == results_.end()) {
      ++without_result;
      continue;
    }
    const ResultMsg& result = it->second;
    relocalizer::EvaluationRecord record;
    record.id = truth.id;
    // The stamp column as `evaluate` writes it: 7-Scenes and 12-Scenes frame
    // numbers rather than the synthesized time.
    record.stamp = integer_stamps ? truth.id : truth.stamp.toSec();
    record.truth = truth.pose;
    if (result.success) record.estimate = fromPoseMsg(result.pose.pose.pose);
    record.message = result.message;
    record.point_inliers = static_cast<int>(result.point_inliers);
    record.line_inliers = static_cast<int>(result.line_inliers);
    record.score = result.score;
    record.surface_agreement = result.surface_agreement;
    record.timings.sampling = result.time_sampling;
    record.timings.forest = result.time_forest;
    record.timings.ransac = result.time_ransac;
    record.timings.refinement = result.time_refinement;
    record.timings.surface = result.time_surface;
    record.timings.total = result.processing_time;
    records.push_back(std::move(record));
    received = std::max(received, result.frames_received);
    processed = std::max(processed, result.frames_processed);
    dropped = std::max(dropped, result.frames_dropped);
  }
  if (records.empty()) {
    ROS_FATAL("replay: no result matches a ground-truth pose (%zu poses, %zu results)",
              truths.size(), results_.size());
    return 1;
  }
  if (without_result)
    std::printf(
        "%d of %zu frames with ground truth got no result (dropped by the node: %u); they "
        "are left out of the table\n",
        without_result, truths.size(), dropped);

  const std::string bag_name =
      options_.play ? std::filesystem::path(options_.bag).filename().string() : "live topics";
  const relocalizer::EvaluationSummary summary = relocalizer::summarizeEvaluation(records);
  std::printf("\n%s", relocalizer::formatEvaluationTable(
                          summary, "replay: " + bag_name + " through " + result_sub_.getTopic())
                          .c_str());
  std::fflush(stdout);
  if (options_.output.empty()) return 0;

  relocalizer::EvaluationOutputOptions out;
  out.integer_stamps = integer_stamps;
  out.title = bag_name + " (replay)";
  nlohmann::json extra;
  extra["model"] = options_.model;
  extra["bag"] = options_.bag;
  extra["dataset"] = dataset_info_;
  extra["result_topic"] = result_sub_.getTopic();
  extra["frames_without_result"] = without_result;
  extra["node"] = {
      {"frames_received", received}, {"frames_processed", processed}, {"frames_dropped", dropped}};
  extra["software_version"] = relocalizer::kSoftwareVersion;
  // Ties the files to the roslaunch run that wrote them.
  std::string run_id;
  if (ros::param::get("/run_id", run_id)) extra["run_id"] = run_id;
  out.extra_json = extra.dump();
  if (const relocalizer::Status written =
          relocalizer::writeEvaluationOutputs(options_.output, records, summary, out);
      !written) {
    ROS_FATAL("replay: %s", written.error().c_str());
    return 1;
  }
  std::printf("wrote poses.txt, errors.csv, summary.json, trajectory.png, errors.png to %s\n",
              options_.output.c_str());
  return 0;
}

}  // namespace relocalizer_ros
