#pragma once
// The learning loop's step, written once for the node, `evaluate
// --learn-frames` and `learn_benchmark`, whichever learner learns (learner.h):
// a frame as SLAM posed it, in order, goes through the key-frame rule
// (key_frame_rule.h); a key frame is loaded, its SLAM pose checked against
// what its images show (slam_pose_check.h), and handed to the learner. A pose
// SLAM could not give, or gave unusable (slamPoseError), is refused here,
// before the rule, which would otherwise measure later frames against it:
// this is the one place a SLAM pose is judged, so learners take what the feed
// hands them. A refused key frame does not become the rule's reference either.

#include <functional>
#include <optional>
#include <string>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/key_frame_rule.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/online/learner.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/online/slam_pose_check.h"

namespace relocalizer {

class KeyFrameFeed {
 public:
  // Into `learner`, which outlives the feed; the rule is params.min_motion,
  // the check params.slam_check.
  KeyFrameFeed(Learner& learner, const LearningParams& params);

  struct Result {
    enum class Outcome {
      Untracked,    // no pose, or an unusable one (`why`): not learned from
      NotKeyFrame,  // too close to the last key frame
      Learned,      // stored; the learner retrains when due
      Covered,      // a key frame, but what is learned already holds one as good (submaps)
      Failed,       // a key frame that could not be loaded or stored (`why`)
      Refused,      // a key frame whose SLAM pose the images or the place contradict (`why`)
    };
    Outcome outcome = Outcome::NotKeyFrame;
    std::string why;
    double store_seconds = 0.0;  // Learned: compressing and storing, on the caller's thread
    // Set on the key frame that showed SLAM's map moved (Refused: learning
    // stopped; Learned: the first of a new place): what moved, to be told loudly.
    std::string map_moved;
  };

  // The next frame with SLAM's camera-to-world pose (nullopt: SLAM lost
  // track). `load` is called only for a key frame (loading or converting a
  // frame costs more than the rule). When the check asks the place, the
  // learner's current places answer, searched as one group; when SLAM's map
  // moved under them, the learner starts a new place if it can.
  Result offer(const std::optional<Pose>& camera_to_world,
               const std::function<Expected<RgbdFrame>()>& load);

  Learner& learner() { return learner_; }
  // Its status is read on any thread (the node's ~result).
  const SlamPoseCheck& check() const { return check_; }

 private:
  Learner& learner_;
  // Both references are the last key frame learned from; the learning thread's.
  KeyFrameSelector selector_;
  SlamPoseCheck check_;
  int map_moves_ = 0;  // the check's, told in a Result
};

}  // namespace relocalizer
