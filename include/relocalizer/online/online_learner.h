#pragma once
// Learning a place while SLAM tracks it: posed key frames in, an ever newer
// Relocalizer out, at any moment.
//
// Method (docs/online_learning.md has the measurements behind it): key frames
// go into a capped, compressed store (keyframe_store.h), and a worker re-trains
// both forests and the scene surface on all stored key frames with the
// ordinary offline training, then swaps the new Relocalizer in. Measured on
// redkitchen, training on the key frames alone scores as well as training on
// every frame, and no structure the package could bring to an unseen place
// (random or synthetic trees with online leaves) came close after the first
// few seconds; a retrain from 2 key frames did. Retrains start once
// `first_retrain` key frames are stored and run again when the store has grown
// by `retrain_growth` of what the current model knows (at least one key
// frame), so the total training work stays a constant factor of one retrain
// of the whole store.
//
// Two modes: Background, a low-priority worker thread for the node; Inline,
// where nothing trains until drain(), so evaluate and the tests are
// deterministic.

#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/key_frame_rule.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/keyframe_store.h"
#include "relocalizer/online/learner.h"
#include "relocalizer/online/setting_name.h"
#include "relocalizer/online/slam_pose_check.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

struct LearningParams {
  KeyFrameMotion min_motion;     // the key-frame rule (key_frame_rule.h) of the feed
  int max_keyframes = 64;        // the store's cap; the oldest of the closest pair goes when full
  int first_retrain = 2;         // key frames before the first model
  double retrain_growth = 0.25;  // retrain when the store has this many more key frames (share)
  int jpeg_quality = 95;         // colour storage
  int worker_threads = 1;        // Background: threads of a retrain (at nice +worker_nice)
  int worker_nice = 10;          // Background: added niceness of the worker thread
  // Samples per tree of a retrain, at most: samples_per_image becomes
  // budget / key frames, between 1000 and the configured value (0: no budget).
  // A retrain then costs about the same at 64 key frames as at 11, so the
  // model lags a full store by seconds, not a minute; below 11 key frames
  // nothing changes (measured: docs/online_learning.md).
  int samples_budget_per_tree = 55000;
  // Key frames are >= 5 cm / 5 deg apart, so few of them see each voxel: the
  // surface keeps voxels seen by this many (the 30 Hz default of 3 drops most
  // of a key-frame surface; measured 77.0 % with 3, 83.5 % with 1 on redkitchen).
  int surface_min_frames = 1;
  // The surface agreement gate (surface_fit.h) assumes a surface that covers
  // what a frame sees; a learned one covers only what the key frames so far
  // saw, so the gate rejects right poses (after 100 redkitchen frames: 10 %
  // with it, 43 % without). Off: answers are still refined by ICP and their
  // agreement reported; the inlier evidence still decides.
  bool surface_gate = false;
  // Learned models backtrack through at least this many leaves per tree. A
  // model of a few key frames has few samples per leaf region, so the right
  // mode is more often a sibling of the leaf reached: after 100 redkitchen
  // frames (11 key frames) 44.0 % with 8 leaves, 40.0 % with the offline
  // default of 4, the same 83.0 % with either after 300 frames.
  int min_backtracking_leaves = 8;
  // The check of SLAM's poses against the images (slam_pose_check.h) in the
  // feed that chooses the key frames (key_frame_feed.h).
  SlamCheckParams slam_check;
  TrainingParams training;  // both forests and the surface, as `train` uses them
};

// Empty when usable, otherwise what is wrong, naming the setting.
std::string learningParamsError(const LearningParams& params, const SettingName& name = {});

// The one reader of the learning settings given as text (the node's
// learn_min_motion and learn_config, the tools' options): `params` with the
// key-frame motion parsed, the training YAML (as `train --config`; empty:
// config/forest.yaml defaults) loaded, and every field checked by
// learningParamsError. Errors name the setting (fields min_motion, config).
Expected<LearningParams> readLearningParams(LearningParams params, const std::string& min_motion,
                                            const std::string& training_config,
                                            const SettingName& name = {});

// The relocalizer parameters a learned model answers with: `params` with two
// overrides a model of a few key frames needs (surface_gate and
// min_backtracking_leaves above say why). The learner applies them to every
// model it serves.
RelocalizerParams learnedModelParams(const LearningParams& learning, RelocalizerParams params);

// Where a retrain's wall time went, in the order the stages run (seconds).
struct RetrainStages {
  double decode = 0.0;    // the stored key frames decompressed
  double surface = 0.0;   // depth fused into the scene surface
  double sampling = 0.0;  // each tree's samples drawn (line detection included)
  double growing = 0.0;   // the trees grown: split search, leaves' mean shift and descriptors
  double serving = 0.0;   // the Relocalizer built on the model and validated
};

struct LearningStatus {
  int keyframes_added = 0;   // accepted since start, resumed ones included
  int keyframes_stored = 0;  // in the store now (<= max_keyframes)
  int keyframes_evicted = 0;
  int keyframes_learned = 0;  // key frames the current model was trained on
  int backlog = 0;            // key frames added since the current model's snapshot was taken
  size_t store_bytes = 0;     // compressed key frames
  size_t model_bytes = 0;     // forests and surface of the current model
  int retrains = 0;           // completed
  bool retraining = false;
  double last_retrain_seconds = 0.0;  // wall time of the last completed retrain
  RetrainStages last_retrain_stages;  // and its stages
  std::string last_error;  // of the last failed retrain or save, or of an interrupted save
                           // found by resume(); empty if none
};

class OnlineLearner : public Learner {
 public:
  enum class Mode { Background, Inline };

  // Every model served answers with learnedModelParams(params, relocalizer_params).
  // Throws std::invalid_argument when learningParamsError(params) says why.
  // `names` name the one place places() gives.
  OnlineLearner(LearningParams params, RelocalizerParams relocalizer_params, Mode mode,
                LearnerNames names = {});
  ~OnlineLearner() override;
  OnlineLearner(const OnlineLearner&) = delete;
  OnlineLearner& operator=(const OnlineLearner&) = delete;

  // Continues a place saved by save(): its model serves at once and counts as
  // trained on `key_frames`; later retrains use them with the new ones. Call
  // before the first addKeyFrame.
  Status resume(Model model, std::vector<StoredKeyFrame> key_frames);
  // Same, from `<model_path>` and `<model_path>.keyframes`. When the key
  // frames were saved with another model (a save interrupted between its two
  // renames), their model is not served: the learner retrains on them as if
  // from nothing, and status().last_error says so, naming both files.
  Status resume(const std::string& model_path);

  // Starts from key frames another learner stored (a submap handing its border
  // to the next, submap_learner.h): shared, not compressed again, and not yet
  // learned (the next retrain trains on them). Call before the first addKeyFrame.
  Status seed(std::vector<KeyFrameStore::Entry> key_frames);
  // The stored key frames, in arrival order.
  std::vector<KeyFrameStore::Entry> keyFrames() const;

  // A key frame with its camera-to-world pose (from SLAM, never from this
  // relocalizer, as the feed checked it: key_frame_feed.h); always Stored.
  // Compresses it on the caller's thread (about 20 ms for 640x480) and wakes
  // the worker; never waits for a retrain.
  Expected<KeyFrameAdded> addKeyFrame(const RgbdFrame& frame, const Pose& camera_to_world) override;

  // Blocks until the current model has been trained on every stored key frame
  // (Inline: retrains now). A failed retrain is returned.
  Status drain() override;

  // The newest model, or null before the first retrain. Callers keep the
  // pointer for as long as they use it; a swap never frees it under them.
  std::shared_ptr<const Relocalizer> current() const;
  // current() as the one place of group names.place, named names.place.
  std::vector<Place> places() const override;
  LearningStatus status() const;
  LearnerSummary summary() const override;

  // Writes the current model to `path` and the stored key frames, bound to
  // it, to keyFramesPath(path), as one unit (core/file_io.h: only the
  // package's own files are replaced; fsynced; key frames renamed first, so
  // an interrupted save is detected by resume()). Fails when there is no
  // model yet.
  Status save(const std::string& path) override;

 private:
  bool retrainDue() const;  // under mutex_
  // Fills the empty store; the current model (if any) counts as trained on them.
  Status adoptKeyFrames(std::vector<KeyFrameStore::Entry> key_frames,
                        std::shared_ptr<const Relocalizer> model, std::string note);
  Status retrain(std::unique_lock<std::mutex>& lock);
  void workerLoop();

  const LearningParams params_;
  const RelocalizerParams relocalizer_params_;
  const Mode mode_;
  const LearnerNames names_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;      // the worker: work or stop
  std::condition_variable progress_;  // drain(): a retrain finished
  KeyFrameStore store_;
  std::shared_ptr<const Relocalizer> current_;
  LearningStatus status_;
  long long generation_ = 0;          // key frames ever added
  long long trained_generation_ = 0;  // generation the newest (or running) retrain started from
  long long model_generation_ = 0;    // generation the current model was trained from
  bool drain_requested_ = false;
  std::atomic<bool> stop_{false};  // also read by a running retrain, to abort it
  std::thread worker_;
};

}  // namespace relocalizer
