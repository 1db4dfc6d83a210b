#pragma once
// The rules /diagnostics judges the node by (node_diagnostics.h): which state
// is OK, WARN or ERROR, and the one-line message that says why. Free of ROS,
// so a test can hold every rule to its state without a master.

#include <string>

namespace relocalizer_ros {

// The levels of diagnostic_msgs/DiagnosticStatus that the node uses.
enum class HealthLevel { Ok, Warn, Error };

struct HealthLimits {
  double input_timeout = 0.0;  // seconds without a synchronised frame before WARN (0: never)
  int max_failures = 0;        // relocalized frames in a row without a pose before WARN (0: never)
};

// What the node knows of itself at one moment.
struct NodeHealth {
  bool usable = false;          // a place (or a learned model) to relocalize against
  std::string unusable_reason;  // why not, when not
  bool any_frame = false;       // a synchronised frame arrived since start
  double since_frame = 0.0;     // seconds since the last one, or since start when none
  int failures_in_a_row = 0;    // frames relocalized without a pose since the last pose
  std::string last_failure;     // the reason of the last of them
  double since_pose = -1.0;     // seconds since the last pose; < 0: none yet
};

struct HealthVerdict {
  HealthLevel level = HealthLevel::Ok;
  std::string message;
};

// ERROR when nothing can be relocalized against; else WARN when inputs stopped
// (they explain failures, so they are named first), or when answers keep failing;
// else OK.
HealthVerdict judgeHealth(const NodeHealth& health, const HealthLimits& limits);

}  // namespace relocalizer_ros
