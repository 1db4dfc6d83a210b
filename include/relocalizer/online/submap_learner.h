#pragma once
// Learning a run too long for one key-frame store (issue 26): the key frames
// are cut into submaps by the submap rule (submap_rule.h); the active submap
// is an OnlineLearner of its own, and when the rule starts a new one the
// active is trained one last time on all its key frames and frozen: its model
// stays, its learner (store, compressed images) goes. Memory then holds one
// store, however far the camera walks. Every submap answers in the same map
// frame, so a frame is searched across them as across places (place_set.h).
//
// The set is saved as one folder (submap_folder.h) and continued from it.
//
// This step freezes on the caller's thread (what evaluate and the tests need:
// deterministic); the node's background freeze and bounding the resident
// frozen models follow (docs/proposals/issue-26-submaps.md).

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/online/submap_rule.h"

namespace relocalizer {

// What the set's places are called: `<place>/<index>` in `map_frame`.
struct SubmapNames {
  std::string place = "learned";
  std::string map_frame = "map";
};

// `learned/3`: the place name of submap `index`.
std::string submapPlaceName(const std::string& place, int index);

// One submap's model, when it has one.
struct SubmapModel {
  int index = 0;  // in the run, from 0 (the place name's suffix)
  bool frozen = false;
  int keyframes = 0;  // the key frames it was (or, active, is being) learned from
  std::shared_ptr<const Relocalizer> relocalizer;
};

// Thread safety: every call but index() and active() takes one lock inside,
// so the node may save() or read models() on another thread than the one that
// feeds key frames. A call waits for the one in progress: a save for a freeze
// (a retrain, seconds) or for drain(), a key frame for a save (the active
// submap's files and the manifest). index() and active() are for the feeding
// thread, between its own calls.
class SubmapLearner {
 public:
  // `learning.max_keyframes` caps each submap. Throws std::invalid_argument
  // when learningParamsError or submapParamsError says why.
  SubmapLearner(LearningParams learning, SubmapParams submaps, RelocalizerParams relocalizer_params,
                SubmapNames names = {});

  // Continues the set saved in `folder` (call before the first key frame):
  // frozen submaps answer again and cover their areas, the active one goes on
  // learning (OnlineLearner::resume), new submaps take the next indices, and
  // `folder` becomes the working folder (useFolder). Fails, naming
  // manifest.json, when the manifest is missing or unreadable: starting over
  // would overwrite the set at the next save. A submap whose model is missing
  // or damaged is skipped (its area is learned again when the camera comes
  // back): the returned warnings, also kept in warnings(), name each such file
  // and why.
  Expected<std::vector<std::string>> resume(const std::string& folder);

  // From now on a frozen submap is written into `folder` (created if need be)
  // when it freezes, and its key frames leave memory; one frozen before is
  // written now. Without a working folder a frozen submap keeps its key
  // frames in memory (compressed, ~185 KB each) until the first save(), which
  // writes them and makes its folder the working folder: frozen files are
  // written once, never again, and memory stays bounded from then on.
  Status useFolder(const std::string& folder);

  // Writes the whole set into `folder` (created if need be; see
  // submap_folder.h): each frozen submap not there yet (copied from the
  // working folder or written from memory), the active submap's model and key
  // frames (the model it has now: no retrain), then manifest.json, each file
  // written then renamed (core/file_io.h: an existing manifest.json that is
  // not ours is refused, not overwritten). Fails when no submap has a model
  // or key frames yet.
  Status save(const std::string& folder);

  // The working folder (empty: none yet).
  std::string workingFolder() const;
  // Warnings of the last resume() and of writes at freezes that failed (a
  // frozen submap then stays in memory and the next save writes it).
  std::vector<std::string> warnings() const;
  const SubmapNames& names() const { return names_; }

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
  // A frozen submap. Why key frames are kept at all: its key-frame file must
  // be written once, and a freeze before any folder was named has nowhere to
  // write it; dropping them would make the first save unable to write the
  // whole set (and a resumed set could not thaw that submap later).
  struct Frozen {
    std::shared_ptr<const Relocalizer> relocalizer;  // null: none learned or loaded
    std::vector<KeyFrameStore::Entry> key_frames;    // until written into folder_
    bool written = false;                            // its pair is in folder_
    ModelFileId model_id;                            // of its model file, once written
  };

  // The active learner's last retrain becomes submap `frozen`'s model; the
  // learner goes; with a working folder the submap is written there.
  Status freezeActive(int frozen);
  // Writes the frozen submaps not yet in `folder`, the active one too when
  // `with_active`, then the manifest; `folder` then becomes the working
  // folder when `adopt`, or when there was none. Under mutex_.
  Status writeSet(const std::string& folder, bool with_active, bool adopt);

  const LearningParams learning_;
  const SubmapParams submap_params_;
  const RelocalizerParams relocalizer_params_;
  const SubmapNames names_;
  mutable std::mutex mutex_;
  SubmapIndex index_;
  std::unique_ptr<OnlineLearner> active_;
  std::vector<Frozen> frozen_;  // by submap index
  std::int64_t next_id_ = 0;
  std::string folder_;  // the working folder; empty: none yet
  std::vector<std::string> warnings_;
};

}  // namespace relocalizer
