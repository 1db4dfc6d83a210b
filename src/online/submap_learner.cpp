#include "relocalizer/online/submap_learner.h"

#include <stdexcept>

#include "relocalizer/forest/model_io.h"

namespace relocalizer {

std::string submapPlaceName(const std::string& place, int index) {
  return place + "/" + std::to_string(index);
}

std::vector<Place> submapPlaces(const std::vector<SubmapModel>& models, const std::string& group,
                                const std::string& map_frame) {
  std::vector<Place> places;
  for (const SubmapModel& m : models)
    places.push_back({submapPlaceName(group, m.index), map_frame, "", m.relocalizer, group});
  return places;
}

SubmapLearner::SubmapLearner(LearningParams learning, SubmapParams submaps,
                             RelocalizerParams relocalizer_params, SubmapNames names,
                             OnlineLearner::Mode mode)
    : learning_(std::move(learning)),
      submap_params_(submaps),
      relocalizer_params_(std::move(relocalizer_params)),
      names_(std::move(names)),
      mode_(mode),
      index_(submaps, learning_.max_keyframes) {
  if (const std::string why = learningParamsError(learning_); !why.empty())
    throw std::invalid_argument(why);
  if (mode_ == OnlineLearner::Mode::Background)
    freezer_ = std::thread(&SubmapLearner::freezeLoop, this);
}

SubmapLearner::~SubmapLearner() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  freeze_cv_.notify_all();
  if (freezer_.joinable()) freezer_.join();
}

Status SubmapLearner::finishFreeze(int index, const OnlineLearner& learner,
                                   const Status& retrained) {
  // No longer freezing before it is written: writeSet leaves out a submap
  // whose freeze runs (its model is not final yet).
  freezing_index_ = -1;
  Frozen& f = frozen_[static_cast<std::size_t>(index)];
  // A submap that fails its last retrain keeps the model it had.
  if (std::shared_ptr<const Relocalizer> last = learner.current()) f.relocalizer = std::move(last);
  if (!retrained) {
    freeze_error_ = "submap " + std::to_string(index) + "'s last retrain: " + retrained.error();
    return makeError(freeze_error_);
  }
  if (folder_.empty() || !f.relocalizer) return okStatus();
  if (Status written = writeSet(folder_, false, true); !written) {
    warnings_.push_back(written.error());
    freeze_error_ = written.error();
    return written;
  }
  return okStatus();
}

void SubmapLearner::freezeLoop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    freeze_cv_.wait(lock, [&] { return freezing_ || stopping_; });
    // Stopping with nothing handed over; a freeze handed over still ends, so
    // that a submap frozen before shutdown has its final model (and files).
    if (!freezing_) return;
    std::shared_ptr<OnlineLearner> learner = freezing_;
    const int index = freezing_index_;
    lock.unlock();
    const Status retrained = learner->drain();
    lock.lock();
    freezing_.reset();
    finishFreeze(index, *learner, retrained);
    lock.unlock();
    learner.reset();  // its store and worker go, outside the lock
    freeze_cv_.notify_all();
    lock.lock();
  }
}

Status SubmapLearner::resumeModelFile(const std::string& path) {
  auto learner = std::make_shared<OnlineLearner>(learning_, relocalizer_params_, mode_);
  if (Status resumed = learner->resume(path); !resumed) return resumed;
  std::vector<SubmapKeyFrame> key_frames;
  for (const KeyFrameStore::Entry& k : learner->keyFrames())
    key_frames.push_back({next_id_++, k->pose});
  added_ = static_cast<int>(key_frames.size());
  index_.restore({std::move(key_frames)}, 0);
  active_ = std::move(learner);
  return okStatus();
}

Expected<SubmapPlacement> SubmapLearner::addKeyFrame(const RgbdFrame& frame,
                                                     const Pose& camera_to_world) {
  if (const std::string why = slamPoseError(camera_to_world); !why.empty())
    return makeError("key frame " + std::to_string(frame.id) + ": " + why);
  // Checked before the index records it: what the store refuses must not be
  // placed (only an encoder failure is left, which the store reports).
  if (const std::string why = frameValidationError(frame); !why.empty())
    return makeError("key frame " + std::to_string(frame.id) + ": " + why);
  SubmapPlacement placement;
  std::shared_ptr<OnlineLearner> active, freezing;
  int was_active = -1;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    // One freeze at a time: a second waits for the first (only this thread
    // changes the index, so the decision holds across the wait).
    if (mode_ == OnlineLearner::Mode::Background && active_) {
      const SubmapDecision next = index_.decide(camera_to_world);
      if (next == SubmapDecision::NewFull || next == SubmapDecision::NewLeft)
        freeze_cv_.wait(lock, [&] { return freezing_index_ < 0; });
    }
    // The index names key frames by arrival, so that the active's store
    // entries (also in arrival order, never evicted: a full submap is
    // replaced, not thinned) line up with its key frames.
    was_active = index_.active();
    placement = index_.place(next_id_++, camera_to_world);
    if (placement.decision == SubmapDecision::Covered) {
      ++covered_;
      return placement;
    }
    ++added_;
    if (placement.decision != SubmapDecision::Active) {
      frozen_.resize(static_cast<std::size_t>(index_.submapCount()));
      std::vector<KeyFrameStore::Entry> seeds;
      if (active_) {
        // A new submap leaves the old one's key frames in the index as they were.
        const std::vector<SubmapKeyFrame>& before = index_.keyFrames(was_active);
        const std::vector<KeyFrameStore::Entry> stored = active_->keyFrames();
        for (const SubmapKeyFrame& seed : placement.seeds)
          for (std::size_t k = 0; k < before.size() && k < stored.size(); ++k)
            if (before[k].id == seed.id) seeds.push_back(stored[k]);
        // Until its last retrain ends the frozen submap answers with the
        // model it has; its key frames are kept until written (Frozen).
        Frozen& f = frozen_[static_cast<std::size_t>(was_active)];
        f.relocalizer = active_->current();
        f.key_frames = stored;
        // A save meanwhile (another thread) waits for it: a frozen submap is
        // written once, with its final model.
        freezing_index_ = was_active;
        if (mode_ == OnlineLearner::Mode::Background) {
          freezing_ = std::move(active_);
          freeze_cv_.notify_all();
        } else {
          freezing = std::move(active_);
        }
      }
      active_ = std::make_shared<OnlineLearner>(learning_, relocalizer_params_, mode_);
      if (Status seeded = active_->seed(std::move(seeds)); !seeded)
        return makeError(seeded.error());
    }
    active = active_;
  }
  // Inline, outside the lock: a retrain takes seconds, and models() may be
  // read meanwhile. A submap that fails its last retrain (or its write) keeps
  // the model it had: the failure is the caller's to report, the run goes on
  // with the new submap, which the index has already started.
  Status frozen = okStatus();
  if (freezing) {
    const Status retrained = freezing->drain();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      frozen = finishFreeze(was_active, *freezing, retrained);
    }
    freeze_cv_.notify_all();
  }
  freezing.reset();  // its store and worker go
  if (Status added = active->addKeyFrame(frame, camera_to_world); !added)
    return makeError(added.error());
  if (!frozen) return makeError(frozen.error());
  return placement;
}

Status SubmapLearner::drain() {
  std::shared_ptr<OnlineLearner> active;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    freeze_cv_.wait(lock, [&] { return freezing_index_ < 0; });
    active = active_;
  }
  return active ? active->drain() : okStatus();
}

std::vector<SubmapModel> SubmapLearner::models() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<SubmapModel> out;
  for (int s = 0; s < index_.submapCount(); ++s) {
    SubmapModel model;
    model.index = s;
    model.frozen = index_.frozen(s);
    model.keyframes = static_cast<int>(index_.keyFrames(s).size());
    if (model.frozen)
      model.relocalizer = s < static_cast<int>(frozen_.size())
                              ? frozen_[static_cast<std::size_t>(s)].relocalizer
                              : nullptr;
    else
      model.relocalizer = active_ ? active_->current() : nullptr;
    if (model.relocalizer) out.push_back(std::move(model));
  }
  return out;
}

SubmapStatus SubmapLearner::status() const {
  SubmapStatus status;
  std::shared_ptr<const OnlineLearner> active;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status.submaps = index_.submapCount();
    for (int s = 0; s < status.submaps; ++s)
      status.submap_keyframes.push_back(static_cast<int>(index_.keyFrames(s).size()));
    status.keyframes_added = added_;
    status.keyframes_covered = covered_;
    status.last_error = freeze_error_;
    status.freezing = freezing_index_ >= 0;
    for (int s = 0; s < static_cast<int>(frozen_.size()); ++s)
      if (s != index_.active() && frozen_[static_cast<std::size_t>(s)].relocalizer)
        status.model_bytes += modelBytes(frozen_[static_cast<std::size_t>(s)].relocalizer->model());
    active = active_;
  }
  if (active) {
    status.active = active->status();
    status.model_bytes += status.active.model_bytes;
    if (!status.active.last_error.empty()) status.last_error = status.active.last_error;
  }
  return status;
}

}  // namespace relocalizer
