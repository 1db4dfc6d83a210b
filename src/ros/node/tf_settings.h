#pragma once
// The node's frames and its TF (REP 105): the map frame it answers in, the
// odom frame it publishes map -> odom to (transform_publisher.h), and how long
// a TF lookup may wait (the publisher, the learning feed, the pose hand-off).

#include <string>

#include "param_reading.h"

namespace relocalizer_ros {

struct TfSettings {
  std::string map_frame = "map";
  std::string odom_frame;  // empty: publish map_frame -> camera frame
  bool publish_tf = true;
  double transform_tolerance = 0.1;  // seconds map -> odom is post-dated by
  double tf_rate = 10.0;             // Hz, map -> odom re-broadcast (0: only on updates)
  double tf_timeout = 0.2;           // seconds to wait for odom -> camera at the frame stamp
};

// map_frame, odom_frame (leading slashes dropped), publish_tf,
// transform_tolerance, tf_rate, tf_timeout.
void readTfSettings(ParamReader& reader, TfSettings& tf);

}  // namespace relocalizer_ros
