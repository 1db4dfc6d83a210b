#pragma once
// Learning a run too long for one key-frame store (issue 26): the key frames
// are cut into submaps by the submap rule (submap_rule.h); the active submap
// is an OnlineLearner of its own, and when the rule starts a new one the
// active is trained one last time on all its key frames and frozen: its model
// stays, its learner (store, compressed images) goes. Memory then holds one
// store, however far the camera walks. Every submap answers in the same map
// frame, so a frame is searched across them as across places (place_set.h).
// The set is saved as one folder (submap_folder.h) and continued from it.
//
// Two modes, as OnlineLearner's. Inline (evaluate, the tests: deterministic):
// a freeze retrains on the caller's thread. Background (the node): each
// submap retrains on its own worker, and a full submap is handed to a queue
// of freezes that one freeze thread works through in order, so the next
// submap starts at once and addKeyFrame waits only when kMaxPendingFreezes
// submaps are already waiting (counted: SubmapStatus::freeze_waits). A
// submap handed over stops its own worker (a retrain it was running is
// aborted), so training memory is at most two retrains, the freeze's and the
// active's, as with one freeze at a time. Until its freeze ends, the frozen
// submap answers with the model it had; its files are written by the freeze
// thread outside the lock that models() takes. Bounding the resident frozen
// models follows (docs/proposals/issue-26-submaps.md).

#include <algorithm>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/online/learner.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/online/serial_worker.h"
#include "relocalizer/online/submap_folder.h"
#include "relocalizer/online/submap_rule.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer {

// What the set's places are called: `<place>/<index>` in `map_frame`.
using SubmapNames = LearnerNames;

// Submaps waiting for their last retrain (Background), the one being
// retrained included, before addKeyFrame waits for room. A pending submap
// holds its compressed key frames (on the 6-room walk at 320 x 240, 44 took
// 1.9 MB, so ~2.8 MB for 64; ~12 MB for 64 at 640 x 480) beside its model,
// which answers anyway. Memory would allow 8 (what a working folder saves by
// writing frozen key frames out, ~60 MB for the walk's 22 submaps), but a
// save, and so the node's shutdown with save_on_exit, waits for every pending
// freeze (each ~50 s of CPU-starved retraining on a loaded robot), and
// roslaunch kills a node 15 s after asking it to stop: 2 keeps that wait to
// two freezes (one more than before the queue) and still starts the next
// submap at once after a burst of one extra submap.
// docs/online_learning.md has the measurements (taken with 8).
constexpr int kMaxPendingFreezes = 2;

// One submap's model, when it has one.
struct SubmapModel {
  int index = 0;  // in the run, from 0 (the place name's suffix)
  bool frozen = false;
  int keyframes = 0;  // the key frames it was (or, active, is being) learned from
  // 1: of the current place (from the last startNewPlace() on); 0: learned in
  // the map SLAM had before (Place::part).
  int part = 1;
  std::shared_ptr<const Relocalizer> relocalizer;
  // A frozen submap's file, once written (or resumed); size 0: none (the
  // active one, whose model changes).
  ModelFileId file;
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
  bool freezing = false;      // a full submap waits for, or runs, its last retrain
  int freezes_pending = 0;    // such submaps now (Background: at most kMaxPendingFreezes)
  int freezes_pending_most = 0;      // most at once since start
  int freeze_waits = 0;              // new submaps that waited for room in the queue, or for a save
  double freeze_wait_seconds = 0.0;  // how long they waited, in all
  LearningStatus active;  // the active submap's learner (zeros before the first key frame)
};

// Thread safety: addKeyFrame, resume and drain from one thread (the learning
// loop), index() and active() from that thread only; models(), status(),
// save() and the rest from any thread at any time. A save waits for the
// freezes pending when it starts (retrains, seconds each: a frozen submap is
// written once, with its final model), and a new submap meanwhile waits for
// the save; a key frame waits for a save's writes (the active submap's files
// and the manifest).
class SubmapLearner : public Learner {
 public:
  // `learning.max_keyframes` caps each submap; `mode` is each submap
  // learner's (online_learner.h). Throws std::invalid_argument when
  // learningParamsError or submapParamsError says why.
  SubmapLearner(LearningParams learning, SubmapParams submaps, RelocalizerParams relocalizer_params,
                SubmapNames names = {}, OnlineLearner::Mode mode = OnlineLearner::Mode::Inline);
  // Background: waits for the pending freezes (their retrains are not
  // aborted: a submap handed over has its final model and files).
  ~SubmapLearner() override;
  SubmapLearner(const SubmapLearner&) = delete;
  SubmapLearner& operator=(const SubmapLearner&) = delete;

  // Continues the set saved in the folder `path` (call before the first key frame):
  // frozen submaps answer again and cover their areas, the active one goes on
  // learning (OnlineLearner::resume), new submaps take the next indices, and
  // `path` becomes the working folder (useFolder). Fails, naming
  // manifest.json, when the manifest is missing or unreadable: starting over
  // would overwrite the set at the next save. A submap whose model is missing
  // or damaged is skipped (its area is learned again when the camera comes
  // back): the returned warnings, also kept in warnings(), name each such file
  // and why. `path` may also be one model file and its key frames
  // (OnlineLearner::save, a place learned before submaps): it becomes the
  // active submap 0, holding those key frames as they are. A model file with
  // no key frames beside it (made by `train`) becomes frozen submap 0 as it
  // is, surveyed (SubmapIndex::surveyedSubmaps): a key frame whose depth lies
  // on its surface is covered (place_change.h: viewKnowledge), one that sees
  // what the survey did not (a changed or unsurveyed part) is learned into
  // new submaps beside it, and the first save writes it into the set. It is
  // served with the relocalizer parameters given here, as a trained model is
  // (not learnedModelParams).
  Expected<std::vector<std::string>> resume(const std::string& path);

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
  Status save(const std::string& folder) override;

  // The working folder (empty: none yet).
  std::string workingFolder() const;
  // Warnings of the last resume() and of writes at freezes that failed (a
  // frozen submap then stays in memory and the next save writes it).
  std::vector<std::string> warnings() const;
  const SubmapNames& names() const { return names_; }

  // A key frame (already chosen by the key-frame rule) with SLAM's
  // camera-to-world pose, as the feed checked it (key_frame_feed.h); a
  // covered key frame is placed nowhere (placement.submap -1), unless what
  // it sees no longer lies on the covering frozen submaps' surface (the place
  // changed there: it is learned again, so the place heals). A new submap
  // freezes the active, which retrains it (seconds: Inline here, Background
  // on the freeze thread); a failed freeze is returned (Inline) or in
  // status().last_error.
  Expected<SubmapPlacement> place(const RgbdFrame& frame, const Pose& camera_to_world);
  // place() as the learning loop sees it: Covered when placed nowhere.
  Expected<KeyFrameAdded> addKeyFrame(const RgbdFrame& frame, const Pose& camera_to_world) override;

  // Every submap's model trained on all its key frames: waits for the
  // pending freezes, then for the active's retrain (Inline: retrains now).
  Status drain() override;

  // Every submap with a model, frozen ones first in order, then the active;
  // `current_place`: only those since the last startNewPlace().
  std::vector<SubmapModel> models(bool current_place = false) const;
  // models() as places `<place>/<index>` of group `place` (submapPlaces).
  std::vector<Place> places() const override;
  // The next key frame starts a new submap, seeded with nothing, and the
  // submaps before it no longer cover key frames nor answer the SLAM check
  // (SubmapIndex::startApart); they still answer in places(). Always true.
  bool startNewPlace() override {
    std::lock_guard<std::mutex> lock(mutex_);
    index_.startApart();
    return true;
  }
  std::vector<Place> currentPlaces() const override;
  SubmapStatus status() const;
  // Key frames learned: frozen submaps whole, the active as far as its model goes.
  LearnerSummary summary() const override;
  const SubmapIndex& index() const { return index_; }
  const SubmapParams& submapParams() const { return submap_params_; }
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

  // A full submap waiting for its last retrain.
  struct Pending {
    int index = 0;
    std::vector<KeyFrameStore::Entry> key_frames;  // all of them, in arrival order
    std::shared_ptr<const Relocalizer> model;      // the one it had when handed over
    bool learned_all = false;                      // that model knows every key frame
  };

  // The first pending submap's freeze, then out of the queue (Background:
  // a job of the freezer's).
  Status freezeFront();
  // A freeze: the last retrain, then the files (into the working folder, if
  // any) under files_mutex_, then the result under mutex_. Takes neither lock
  // on entry. A failed retrain leaves the submap the model it had.
  Status freeze(const Pending& pending);
  bool pending(int index) const {  // under mutex_
    return std::any_of(pending_.begin(), pending_.end(),
                       [&](const Pending& p) { return p.index == index; });
  }
  // The manifest of the frozen submaps written into the working folder
  // `folder`, `finished` among them though still pending (its freeze is
  // ending), built under mutex_ and written outside it (the caller holds
  // files_mutex_).
  Status writeManifest(const std::string& folder, int finished);
  // Writes the frozen submaps not yet in `folder`, the active one too when
  // `with_active`, then the manifest; `folder` then becomes the working
  // folder when `adopt`, or when there was none. Under mutex_.
  Status writeSet(const std::string& folder, bool with_active, bool adopt);

  const LearningParams learning_;
  const SubmapParams submap_params_;
  const RelocalizerParams relocalizer_params_;
  const SubmapNames names_;
  const OnlineLearner::Mode mode_;
  // Writers of folders (save, useFolder, a freeze's files); taken before
  // mutex_, never while waiting for a freeze.
  std::mutex files_mutex_;
  mutable std::mutex mutex_;  // everything below; never held across a retrain or compression
  std::condition_variable freeze_cv_;  // a freeze ended, or a save ended
  std::deque<Pending> pending_;        // in order; the front's freeze runs (Background)
  int saves_waiting_ = 0;  // saves waiting for the pending freezes: no hand-over meanwhile
  int pending_most_ = 0, freeze_waits_ = 0;
  double freeze_wait_seconds_ = 0.0;
  SubmapIndex index_;
  std::shared_ptr<OnlineLearner> active_;
  std::vector<Frozen> frozen_;  // by submap index
  std::int64_t next_id_ = 0;
  int added_ = 0, covered_ = 0;
  std::string freeze_error_;
  std::string folder_;  // the working folder; empty: none yet
  std::vector<std::string> warnings_;
  // Background only: the freezes in order, and the stopping of handed-over
  // learners. Last, so they start after the rest is built.
  std::unique_ptr<SerialWorker> freezer_, retirer_;
};

}  // namespace relocalizer
