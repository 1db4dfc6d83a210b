#pragma once
// The key-frame rule: a 30 Hz recording holds many near-duplicate frames,
// which cost training time and teach nothing new. A frame is kept when the
// camera moved or turned enough since the last kept frame. The learner's feed
// (online/key_frame_feed.h) and rosbags read as datasets (`train --bag`) choose
// their frames by it; the key-frame store measures redundancy in its default
// step. It is in core, beside the frame-id sets (id_ranges.h), because it needs
// only poses and both sides use it: in data, the learner (and so the node)
// would link the dataset readers; in online, the bag reader linked the learner.

#include <optional>
#include <string>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"

namespace relocalizer {

// Motion between key frames; the defaults are the rule's default step.
struct KeyFrameMotion {
  double metres = 0.05;
  double degrees = 5.0;
  bool active() const { return metres > 0 || degrees > 0; }
};

// "0.05,5" -> 0.05 m, 5 degrees; "0.1" -> 0.1 m, no turn; "0" or "0,0" turns
// selection off. The error quotes the text and says what is expected.
Expected<KeyFrameMotion> parseMinMotion(const std::string& text);
// The text parseMinMotion reads back ("0.05,5" for the default step).
std::string formatMinMotion(const KeyFrameMotion& motion);

// Distance in default steps: metres / 0.05 + degrees / 5. The store ranks key
// frames by it whatever motion selected them, so a store saved under one
// setting evicts the same way when resumed under another.
double keyFrameDistance(const Pose& a, const Pose& b);

class KeyFrameSelector {
 public:
  explicit KeyFrameSelector(KeyFrameMotion motion) : motion_(motion) {}
  // Both 0 keeps every frame.
  KeyFrameSelector(double min_translation, double min_rotation_degrees)
      : motion_{min_translation, min_rotation_degrees} {}

  bool active() const { return motion_.active(); }

  // Offered frames in order: true when `pose` (camera-to-map) is a key frame,
  // i.e. the first, or at least the motion's metres or degrees from the last
  // key frame. A key frame becomes the new reference.
  bool keep(const Pose& pose);
  // keep() in two steps, for a caller that may still refuse the key frame
  // (the learning feed's SLAM check): a refused one must not become the
  // reference later frames are measured from.
  bool due(const Pose& pose) const;
  void take(const Pose& pose) { last_ = pose; }

 private:
  KeyFrameMotion motion_;
  std::optional<Pose> last_;
};

}  // namespace relocalizer
