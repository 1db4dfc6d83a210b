#pragma once
// Learning a run too long for one key-frame store (issue 26): the key frames
// are cut into submaps by the submap rule (submap_rule.h); the active submap
// is an OnlineLearner of its own, and when the rule starts a new one the
// active is trained one last time on all its key frames and frozen: its model
// stays, its learner (store, compressed images) goes. Memory then holds one
// store, however far the camera walks. Every submap answers in the same map
// frame, so a frame is searched across them as across places (place_set.h).
//
// This step freezes on the caller's thread (what evaluate and the tests need:
// deterministic); the node's background freeze, saving the set as a folder and
// bounding the resident frozen models follow (docs/proposals/issue-26-submaps.md).

#include <cstdint>
#include <memory>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/online/submap_rule.h"

namespace relocalizer {

// One submap's model, when it has one.
struct SubmapModel {
  int index = 0;  // in the run, from 0 (the place name's suffix)
  bool frozen = false;
  int keyframes = 0;  // the key frames it was (or, active, is being) learned from
  std::shared_ptr<const Relocalizer> relocalizer;
};

class SubmapLearner {
 public:
  // `learning.max_keyframes` caps each submap. Throws std::invalid_argument
  // when learningParamsError or submapParamsError says why.
  SubmapLearner(LearningParams learning, SubmapParams submaps,
                RelocalizerParams relocalizer_params);

  // A key frame (already chosen by the key-frame rule) with SLAM's
  // camera-to-world pose. Refused when slamPoseError says why; a covered key
  // frame is placed nowhere (placement.submap -1). A new submap freezes the
  // active first, which retrains it (seconds).
  Expected<SubmapPlacement> addKeyFrame(const RgbdFrame& frame, const Pose& camera_to_world);

  // The active submap's model trained on all its key frames (a retrain now).
  Status drain();

  // Every submap with a model, frozen ones first in order, then the active.
  std::vector<SubmapModel> models() const;
  const SubmapIndex& index() const { return index_; }
  // The active submap's learner, or null before the first key frame.
  const OnlineLearner* active() const { return active_.get(); }

 private:
  // The active learner's last retrain becomes submap `frozen`'s model; the learner goes.
  Status freezeActive(int frozen);

  LearningParams learning_;
  RelocalizerParams relocalizer_params_;
  SubmapIndex index_;
  std::unique_ptr<OnlineLearner> active_;
  std::vector<std::shared_ptr<const Relocalizer>> frozen_;  // by submap index; null: none learned
  std::int64_t next_id_ = 0;
};

}  // namespace relocalizer
