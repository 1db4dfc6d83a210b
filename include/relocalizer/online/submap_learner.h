#pragma once
// Learning a run too long for one key-frame store (issue 26): the key frames
// are cut into submaps by the submap rule (submap_rule.h); the active submap
// is an OnlineLearner of its own, and when the rule starts a new one the
// active is trained one last time on all its key frames and frozen: its model
// stays, its learner (store, compressed images) goes. Memory then holds one
// store, however far the camera walks. Every submap answers in the same map
// frame, so a frame is searched across them as across places (place_set.h).
//
// Two modes, as OnlineLearner's. Inline (evaluate, the tests: deterministic):
// a freeze retrains on the caller's thread. Background (the node): each
// submap retrains on its own worker, and a freeze is handed to a freeze
// thread, so addKeyFrame never waits for it unless a second freeze comes
// while the first still runs (one at most: memory holds the freezing store
// and the active's, never more). Until its freeze ends, the frozen submap
// answers with the model it had. Saving the set as a folder and bounding the
// resident frozen models follow (docs/proposals/issue-26-submaps.md).
//
// Threads: addKeyFrame, resume and drain from one thread (the learning loop);
// models(), status() and activeLearner() from any, at any time.

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
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

// What a run of submaps holds now.
struct SubmapStatus {
  int submaps = 0;  // started (frozen ones and the active)
  // Key frames of each submap (seeds included), by index.
  std::vector<int> submap_keyframes;
  int keyframes_added = 0;    // stored in some submap since start (resumed ones too, seeds once)
  int keyframes_covered = 0;  // key frames a frozen submap already held one as good as: not stored
  size_t model_bytes = 0;     // every submap's model
  std::string last_error;     // the active's (online_learner.h), else of the last failed freeze
  bool freezing = false;      // Background: a full submap's last retrain is running
  LearningStatus active;      // the active submap's learner (zeros before the first key frame)
};

class SubmapLearner {
 public:
  // `learning.max_keyframes` caps each submap; `mode` is each submap
  // learner's (online_learner.h). Throws std::invalid_argument when
  // learningParamsError or submapParamsError says why.
  SubmapLearner(LearningParams learning, SubmapParams submaps, RelocalizerParams relocalizer_params,
                OnlineLearner::Mode mode = OnlineLearner::Mode::Inline);
  // Background: waits for a freeze that is running (its retrain is not aborted).
  ~SubmapLearner();
  SubmapLearner(const SubmapLearner&) = delete;
  SubmapLearner& operator=(const SubmapLearner&) = delete;

  // Continues a place saved as one model file and its key frames
  // (OnlineLearner::save): it becomes submap 0, active, holding those key
  // frames as they are (the rule does not re-cut them). Call before the first
  // addKeyFrame.
  Status resume(const std::string& model_path);

  // A key frame (already chosen by the key-frame rule) with SLAM's
  // camera-to-world pose. Refused when slamPoseError says why; a covered key
  // frame is placed nowhere (placement.submap -1). A new submap freezes the
  // active, which retrains it (seconds: Inline here, Background on the freeze
  // thread); a failed freeze is returned (Inline) or in status().last_error.
  Expected<SubmapPlacement> addKeyFrame(const RgbdFrame& frame, const Pose& camera_to_world);

  // Every submap's model trained on all its key frames: waits for a running
  // freeze, then for the active's retrain (Inline: retrains now).
  Status drain();

  // Every submap with a model, frozen ones first in order, then the active.
  std::vector<SubmapModel> models() const;
  SubmapStatus status() const;
  // Not thread-safe: for the learning thread (and single-threaded callers).
  const SubmapIndex& index() const { return index_; }
  // The active submap's learner, or null before the first key frame.
  const OnlineLearner* active() const { return active_.get(); }
  // The same, shared (a freeze meanwhile does not destroy it under the
  // caller), with the submap count read at the same moment.
  std::shared_ptr<const OnlineLearner> activeLearner(int* submaps = nullptr) const;

 private:
  // Background: the freeze thread's loop.
  void freezeLoop();
  // A freeze's end, under mutex_: the learner's last model becomes the submap's.
  void frozen(int index, const OnlineLearner& learner, const Status& retrained);

  LearningParams learning_;
  RelocalizerParams relocalizer_params_;
  OnlineLearner::Mode mode_;
  mutable std::mutex mutex_;  // everything below; never held across a retrain or compression
  std::condition_variable freeze_cv_;        // a freeze handed over, ended, or stopping
  std::shared_ptr<OnlineLearner> freezing_;  // Background: the submap being frozen
  int freezing_index_ = -1;
  bool stopping_ = false;
  SubmapIndex index_;
  std::shared_ptr<OnlineLearner> active_;
  std::vector<std::shared_ptr<const Relocalizer>> frozen_;  // by submap index; null: none learned
  std::int64_t next_id_ = 0;
  int added_ = 0, covered_ = 0;
  std::string freeze_error_;
  std::thread freezer_;  // Background only; last, so it starts after the rest is built
};

}  // namespace relocalizer
