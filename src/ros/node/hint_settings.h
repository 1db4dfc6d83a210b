#pragma once
// How long a pose hint holds (node_hints.h).

#include "param_reading.h"

namespace relocalizer_ros {

struct HintSettings {
  // Seconds an `initialpose` hint holds for the relocalizations after it,
  // until one answers with a pose.
  double hint_timeout = 10.0;
};

// A hint older than an hour describes a robot that has long moved on.
constexpr double kMinHintTimeout = 0.01, kMaxHintTimeout = 3600.0;

inline void readHintSettings(ParamReader& reader, HintSettings& hints) {
  reader.read("hint_timeout", hints.hint_timeout);
  if (reader.ok())
    reader.bound("hint_timeout", hints.hint_timeout, kMinHintTimeout, kMaxHintTimeout, "s");
}

}  // namespace relocalizer_ros
