#include "relocalize_service.h"

#include <boost/bind/bind.hpp>
#include <cmath>
#include <limits>

#include "node_text.h"

namespace relocalizer_ros {

namespace {

using Clock = std::chrono::steady_clock;

// A call that waited this long for a thread before it ran says so.
constexpr double kQueuedReportSeconds = 0.1;

}  // namespace

RelocalizeService::RelocalizeService(ros::NodeHandle private_nh, const InputSettings& params,
                                     Sources sources, ServiceCallQueue& calls)
    : params_(params), sources_(std::move(sources)) {
  auto options = ros::AdvertiseServiceOptions::create<relocalizer::Relocalize>(
      "relocalize",
      boost::bind(&RelocalizeService::onRelocalize, this, boost::placeholders::_1,
                  boost::placeholders::_2),
      ros::VoidConstPtr(), &calls);
  server_ = private_nh.advertiseService(options);
}

RelocalizeService::ResultMsg RelocalizeService::processShared(uint64_t seq,
                                                              const FrameInputPtr& input) {
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
  ResultMsg result = sources_.process(*input, nullptr);
  promise.set_value(result);
  std::lock_guard<std::mutex> lock(shared_mutex_);
  in_flight_.erase(seq);
  return result;
}

RelocalizeService::ResultMsg RelocalizeService::processHinted(
    const relocalizer::Relocalize::Request& request, const FrameInputPtr& input) {
  const relocalizer::Expected<relocalizer::PoseHint> hint = sources_.read_hint(request.hint);
  if (hint) return sources_.process(*input, &*hint);
  ResultMsg result =
      sources_.output->failure(input->colour->header.stamp, "hint refused: " + hint.error());
  if (log_.allow(result.message))
    ROS_WARN("relocalizer: %s: %s", name().c_str(), result.message.c_str());
  sources_.output->report(result);
  return result;
}

bool RelocalizeService::onRelocalize(relocalizer::Relocalize::Request& request,
                                     relocalizer::Relocalize::Response& response) {
  const ResultMsg result = call(request);
  response.success = result.success;
  response.message = result.message;
  response.pose = result.pose;
  response.place = result.place;
  response.point_inliers = result.point_inliers;
  response.line_inliers = result.line_inliers;
  response.score = result.score;
  response.surface_agreement = result.surface_agreement;
  response.processing_time = result.processing_time;
  // A failed relocalization is an answer, not a transport error: returning
  // false would hide the message from the caller.
  return true;
}

RelocalizeService::ResultMsg RelocalizeService::call(
    const relocalizer::Relocalize::Request& request) {
  ResultMsg result;
  if (std::isnan(request.timeout) || request.timeout == std::numeric_limits<double>::infinity()) {
    // NaN is no duration, and an endless wait would hold one of the few
    // service threads for good: both are refused at once.
    result = sources_.output->failure(
        ros::Time::now(), std::string("timeout must be a finite number of seconds (got ") +
                              (std::isnan(request.timeout) ? "NaN" : "infinity") +
                              "); 0 or less means ~service_timeout (" +
                              secondsText(params_.service_timeout) + " s)");
    if (log_.allow("service timeout"))
      ROS_WARN("relocalizer: %s: %s", name().c_str(), result.message.c_str());
    sources_.output->report(result);
  } else {
    const double asked = request.timeout > 0.0 ? request.timeout : params_.service_timeout;
    const double timeout = std::min(asked, kMaxServiceWaitSeconds);
    // The wait counts from the call's arrival: time spent queued behind other
    // calls is part of what the caller waited.
    const Clock::time_point arrival = ServiceCallQueue::callArrival();
    const auto deadline = arrival + std::chrono::duration_cast<Clock::duration>(
                                        std::chrono::duration<double>(timeout));
    const double queued = std::chrono::duration<double>(Clock::now() - arrival).count();
    const uint64_t after = request.wait_for_next ? sources_.frames->lastSeq() : 0;
    auto entry = sources_.frames->newest(after, deadline);
    if (entry) {
      result = request.use_hint ? processHinted(request, entry->value)
                                : processShared(entry->seq, entry->value);
    } else {
      const std::string capped =
          asked > kMaxServiceWaitSeconds
              ? " (the longest wait a call can ask for; it asked " + secondsText(asked) + " s)"
              : "";
      const std::string behind =
          queued >= kQueuedReportSeconds
              ? ", " + secondsText(queued) + " s of it queued behind other calls"
              : "";
      result = sources_.output->failure(
          ros::Time::now(), std::string(request.wait_for_next ? "no new" : "no") +
                                " synchronised frame within " + secondsText(timeout) + " s" +
                                capped + behind + "; " + sources_.input_status());
      if (log_.allow("service without frame"))
        ROS_WARN("relocalizer: %s: %s", name().c_str(), result.message.c_str());
      sources_.output->report(result);
    }
  }
  return result;
}
}  // namespace relocalizer_ros
