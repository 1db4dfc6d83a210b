#pragma once
// The key-frame rule lives in relocalizer/online/key_frame_rule.h; these names
// keep the ROS layer's callers (the node, its parameters, the bag reader)
// compiling until they use it directly.

#include <string>
#include <utility>

#include "relocalizer/online/key_frame_rule.h"

namespace relocalizer_ros {

using relocalizer::KeyFrameSelector;

// (metres, degrees), as the callers of this header read it.
inline relocalizer::Expected<std::pair<double, double>> parseMinMotion(const std::string& text) {
  auto motion = relocalizer::parseMinMotion(text);
  if (!motion) return relocalizer::makeError(motion.error());
  return std::pair<double, double>(motion->metres, motion->degrees);
}

}  // namespace relocalizer_ros
