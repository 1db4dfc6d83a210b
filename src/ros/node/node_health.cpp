#include "node_health.h"

#include "node_text.h"

namespace relocalizer_ros {

HealthVerdict judgeHealth(const NodeHealth& health, const HealthLimits& limits) {
  if (!health.usable) return {HealthLevel::Error, "no usable place: " + health.unusable_reason};
  if (limits.input_timeout > 0.0 && health.since_frame >= limits.input_timeout)
    return {HealthLevel::Warn, std::string(health.any_frame ? "inputs stopped: no camera frame for "
                                                            : "no camera frame since start, ") +
                                   secondsText(health.since_frame) + " s (input_timeout " +
                                   secondsText(limits.input_timeout) + " s)"};
  if (limits.max_failures > 0 && health.failures_in_a_row >= limits.max_failures)
    return {HealthLevel::Warn, std::to_string(health.failures_in_a_row) +
                                   " frames in a row without a pose: " + health.last_failure};
  if (health.since_pose < 0.0) return {HealthLevel::Ok, "ready, no pose yet"};
  return {HealthLevel::Ok, "last pose " + secondsText(health.since_pose) + " s ago"};
}

}  // namespace relocalizer_ros
