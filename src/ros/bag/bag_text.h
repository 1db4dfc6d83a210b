#pragma once
// How the rosbag readers write topics, stamps and numbers into their summaries
// and errors, so every message names them the same way.

#include <ros/time.h>

#include <cstdio>
#include <string>

namespace relocalizer_ros {

// Topic names compare without regard to a leading slash: "camera/rgb/image_raw"
// on the command line names "/camera/rgb/image_raw" in the bag.
inline std::string normalTopic(const std::string& topic) {
  return topic.empty() || topic[0] == '/' ? topic : "/" + topic;
}

// Seconds with microseconds.
inline std::string seconds(const ros::Time& t) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6f", t.toSec());
  return buffer;
}

inline std::string number(double value, const char* format = "%g") {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

}  // namespace relocalizer_ros
