#include "tf_settings.h"

#include "../conversion/message_conversion.h"

namespace relocalizer_ros {

namespace {

// tf2's default cache is 10 s: a map -> odom post-dated further outlives any
// consumer's history, and keeps a stale localization looking current.
constexpr double kMaxTransformTolerance = 10.0;
// A re-broadcast period longer than 100 s is ten times tf2's cache: its
// transforms have expired long before the next one; 0 says "only on updates"
// honestly. Faster than 1 kHz only floods /tf.
constexpr double kMinTfRate = 0.01, kMaxTfRate = 1000.0;
// The lookup blocks the worker or a service thread; SLAM 10 s late at a
// frame's stamp is not tracking it.
constexpr double kMaxTfTimeout = 10.0;

}  // namespace

void readTfSettings(ParamReader& reader, TfSettings& tf) {
  reader.read("map_frame", tf.map_frame);
  reader.read("odom_frame", tf.odom_frame);
  reader.read("publish_tf", tf.publish_tf);
  reader.read("transform_tolerance", tf.transform_tolerance);
  reader.read("tf_rate", tf.tf_rate);
  reader.read("tf_timeout", tf.tf_timeout);
  if (!reader.ok()) return;
  tf.map_frame = stripLeadingSlashes(tf.map_frame);
  tf.odom_frame = stripLeadingSlashes(tf.odom_frame);
  if (tf.map_frame.empty()) return reader.fail(reader.quoted("map_frame") + " is empty");
  if (tf.odom_frame == tf.map_frame)
    return reader.fail(reader.quoted("odom_frame") + " equals map_frame");
  reader.bound("transform_tolerance", tf.transform_tolerance, 0.0, kMaxTransformTolerance, "s");
  reader.bound("tf_rate", tf.tf_rate, kMinTfRate, kMaxTfRate, "Hz", "only on updates");
  reader.bound("tf_timeout", tf.tf_timeout, 0.0, kMaxTfTimeout, "s");
}

}  // namespace relocalizer_ros
