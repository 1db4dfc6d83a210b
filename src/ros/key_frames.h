#pragma once
// Key-frame selection: a 30 Hz recording holds many near-duplicate frames,
// which cost training time and teach nothing new. A frame is kept when the
// camera moved or turned enough since the last kept frame.

#include <optional>
#include <string>
#include <utility>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"

namespace relocalizer_ros {

// "0.05,5" -> (0.05 m, 5 degrees); "0" or "0,0" turns selection off.
relocalizer::Expected<std::pair<double, double>> parseMinMotion(const std::string& text);

class KeyFrameSelector {
 public:
  // Both 0 keeps every frame.
  KeyFrameSelector(double min_translation, double min_rotation_degrees)
      : min_translation_(min_translation), min_rotation_degrees_(min_rotation_degrees) {}

  bool active() const { return min_translation_ > 0 || min_rotation_degrees_ > 0; }

  // Offered frames in order: true when `pose` (camera-to-map) is a key frame,
  // i.e. the first, or at least min_translation metres or min_rotation_degrees
  // from the last key frame. A key frame becomes the new reference.
  bool keep(const relocalizer::Pose& pose);

 private:
  double min_translation_;
  double min_rotation_degrees_;
  std::optional<relocalizer::Pose> last_;
};

}  // namespace relocalizer_ros
