#pragma once
// The learning loop's step, written once for the node, `evaluate
// --learn-frames` and `learn_benchmark`: a frame as SLAM posed it, in order,
// goes through the key-frame rule (key_frame_rule.h); a key frame is loaded,
// its SLAM pose checked against what its images show (slam_pose_check.h), and
// handed to the learner (online_learner.h), whose store keeps it and whose
// worker retrains on it. A pose SLAM could not give, or gave unusable
// (slamPoseError), is checked before the rule, which would otherwise measure
// later frames against it; a refused key frame does not become the rule's
// reference either.

#include <functional>
#include <optional>
#include <string>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/key_frame_rule.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/online/slam_pose_check.h"
#include "relocalizer/online/submap_learner.h"

namespace relocalizer {

// What the feed keeps between frames: the rule's and the check's reference,
// both the last key frame learned from.
struct FeedTrack {
  explicit FeedTrack(const LearningParams& params)
      : selector(params.min_motion), check(params.slam_check) {}
  KeyFrameSelector selector;
  SlamPoseCheck check;
};

class KeyFrameFeed {
 public:
  // The learner's parameters and mode (online_learner.h); the rule is
  // params.min_motion.
  KeyFrameFeed(LearningParams params, RelocalizerParams relocalizer_params,
               OnlineLearner::Mode mode);

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
  };

  // The next frame with SLAM's camera-to-world pose (nullopt: SLAM lost
  // track). `load` is called only for a key frame (loading or converting a
  // frame costs more than the rule). The learner's current model answers
  // for the place when the check asks it.
  Result offer(const std::optional<Pose>& camera_to_world,
               const std::function<Expected<RgbdFrame>()>& load);

  // Where a key frame goes: true stored, false covered by what is learned
  // (not stored), or why it failed.
  using Store = std::function<Expected<bool>(const RgbdFrame& frame, const Pose& camera_to_world)>;
  // offer()'s steps for a learner the caller holds (submap_learner.h): the
  // rule and the check in `track`, the key frame to `store`, the place's
  // answer for the check from `answer` (empty: no place to ask yet).
  static Result offerTo(FeedTrack& track, const std::optional<Pose>& camera_to_world,
                        const std::function<Expected<RgbdFrame>()>& load, const Store& store,
                        const SlamPoseCheck::AskPlace& answer = {});
  // The store of a learner of submaps: true stored, false covered by a frozen submap.
  static Store storeIn(SubmapLearner& submaps);

  OnlineLearner& learner() { return learner_; }
  const OnlineLearner& learner() const { return learner_; }
  const KeyFrameMotion& motion() const { return motion_; }
  const SlamPoseCheck& check() const { return track_.check; }

 private:
  KeyFrameMotion motion_;
  FeedTrack track_;
  OnlineLearner learner_;
};

}  // namespace relocalizer
