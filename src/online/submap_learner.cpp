#include "relocalizer/online/submap_learner.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <stdexcept>

#include "relocalizer/forest/model_io.h"

namespace relocalizer {

std::string submapPlaceName(const std::string& place, int index) {
  return place + "/" + std::to_string(index);
}

std::vector<Place> submapPlaces(const std::vector<SubmapModel>& models, const std::string& group,
                                const std::string& map_frame) {
  std::vector<Place> places;
  // A frozen submap is its file: the same file loaded as another place into
  // the frame is refused (place_set.h).
  for (const SubmapModel& m : models)
    places.push_back({submapPlaceName(group, m.index), map_frame, "", m.relocalizer, group,
                      m.file.size ? modelIdentity(m.file.crc, m.file.size) : std::string()});
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
  if (mode_ == OnlineLearner::Mode::Background) {
    freezer_ = std::thread(&SubmapLearner::freezeLoop, this);
    retirer_ = std::thread(&SubmapLearner::retireLoop, this);
  }
}

SubmapLearner::~SubmapLearner() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  freeze_cv_.notify_all();
  if (freezer_.joinable()) freezer_.join();
  if (retirer_.joinable()) retirer_.join();
}

bool SubmapLearner::pending(int index) const {
  return std::any_of(pending_.begin(), pending_.end(),
                     [&](const Pending& p) { return p.index == index; });
}

Status SubmapLearner::freeze(const Pending& p) {
  std::shared_ptr<const Relocalizer> model = p.model;
  Status retrained = okStatus();
  if (!p.learned_all) {
    // A learner of its own, seeded with the submap's key frames in their
    // order: the retrain the submap's learner would have run at drain()
    // (Background: on a nice worker), without that learner's store or worker.
    OnlineLearner learner(learning_, relocalizer_params_, mode_);
    retrained = learner.seed(p.key_frames);
    if (retrained) retrained = learner.drain();
    if (std::shared_ptr<const Relocalizer> last = learner.current()) model = std::move(last);
  }
  // Frozen files are written once, with the final model, so the pair is
  // written before the submap counts as frozen; writers of the same folder
  // (a save, useFolder, the manifest) wait on files_mutex_, readers of the
  // models do not.
  std::lock_guard<std::mutex> files(files_mutex_);
  std::string folder;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    folder = folder_;
  }
  Status written = okStatus();
  ModelFileId model_id;
  const bool write = retrained && model && !folder.empty();
  if (write) written = writeFrozenPair(folder, p.index, *model, p.key_frames, model_id);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Frozen& f = frozen_[static_cast<std::size_t>(p.index)];
    // A submap that fails its last retrain keeps the model it had.
    f.relocalizer = model;
    if (write && written) {
      f.written = true;
      f.model_id = model_id;
    } else {
      // Kept until a save (or useFolder) writes them.
      f.key_frames = p.key_frames;
    }
    if (!retrained) {
      freeze_error_ = "submap " + std::to_string(p.index) + "'s last retrain: " + retrained.error();
      return makeError(freeze_error_);
    }
    if (!written) {
      warnings_.push_back(written.error());
      freeze_error_ = written.error();
      return written;
    }
  }
  if (!write) return okStatus();
  // The working folder's manifest names the submap from now on; a failure
  // leaves its pair unnamed (resume warns of it) until the next manifest.
  if (Status named = writeManifest(folder, p.index); !named) {
    std::lock_guard<std::mutex> lock(mutex_);
    warnings_.push_back(named.error());
    freeze_error_ = named.error();
    return named;
  }
  return okStatus();
}

void SubmapLearner::freezeLoop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    freeze_cv_.wait(lock, [&] { return !pending_.empty() || stopping_; });
    // Stopping with nothing handed over; freezes handed over still end, so
    // that a submap frozen before shutdown has its final model (and files).
    if (pending_.empty()) return;
    const Pending next = pending_.front();
    lock.unlock();
    (void)freeze(next);  // a failure is in status().last_error and warnings()
    lock.lock();
    pending_.pop_front();
    freeze_cv_.notify_all();
  }
}

void SubmapLearner::retireLoop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    freeze_cv_.wait(lock, [&] { return !retiring_.empty() || stopping_; });
    std::vector<std::shared_ptr<OnlineLearner>> retired;
    retired.swap(retiring_);
    lock.unlock();
    retired.clear();  // each stops its worker: a running retrain is aborted
    lock.lock();
    if (stopping_ && retiring_.empty()) return;
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

Expected<SubmapPlacement> SubmapLearner::place(const RgbdFrame& frame,
                                               const Pose& camera_to_world) {
  // Checked before the index records it: what the store refuses must not be
  // placed (only an encoder failure is left, which the store reports).
  if (const std::string why = frameValidationError(frame); !why.empty())
    return makeError("key frame " + std::to_string(frame.id) + ": " + why);
  SubmapPlacement placement;
  std::shared_ptr<OnlineLearner> active;
  std::optional<Pending> inline_freeze;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    // A new submap waits for room in the queue, and for a save waiting for
    // the queue (either mode: an Inline freeze is pending while it runs, and
    // a save meanwhile would leave it out). Only this thread changes the
    // index, so the decision holds across the wait.
    const auto room = [&] {
      return saves_waiting_ == 0 && static_cast<int>(pending_.size()) < kMaxPendingFreezes;
    };
    if (active_ && !room()) {
      const SubmapDecision next = index_.decide(camera_to_world);
      if (next == SubmapDecision::NewFull || next == SubmapDecision::NewLeft) {
        const auto start = std::chrono::steady_clock::now();
        freeze_cv_.wait(lock, room);
        ++freeze_waits_;
        freeze_wait_seconds_ +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      }
    }
    // The index names key frames by arrival, so that the active's store
    // entries (also in arrival order, never evicted: a full submap is
    // replaced, not thinned) line up with its key frames.
    const int was_active = index_.active();
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
        Pending handed;
        handed.index = was_active;
        handed.key_frames = active_->keyFrames();
        for (const SubmapKeyFrame& seed : placement.seeds)
          for (std::size_t k = 0; k < before.size() && k < handed.key_frames.size(); ++k)
            if (before[k].id == seed.id) seeds.push_back(handed.key_frames[k]);
        const LearningStatus learned = active_->status();
        handed.model = active_->current();
        handed.learned_all = handed.model && learned.backlog == 0 && !learned.retraining;
        // Until its last retrain ends the frozen submap answers with the
        // model it has; a save meanwhile waits for it (a frozen submap is
        // written once, with its final model).
        frozen_[static_cast<std::size_t>(was_active)].relocalizer = handed.model;
        pending_.push_back(std::move(handed));
        pending_most_ = std::max(pending_most_, static_cast<int>(pending_.size()));
        if (mode_ == OnlineLearner::Mode::Background) {
          retiring_.push_back(std::move(active_));
          freeze_cv_.notify_all();
        } else {
          inline_freeze = pending_.back();
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
  if (inline_freeze) {
    frozen = freeze(*inline_freeze);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      pending_.pop_front();
    }
    freeze_cv_.notify_all();
  }
  if (auto added = active->addKeyFrame(frame, camera_to_world); !added)
    return makeError(added.error());
  if (!frozen) return makeError(frozen.error());
  return placement;
}

Expected<KeyFrameAdded> SubmapLearner::addKeyFrame(const RgbdFrame& frame,
                                                   const Pose& camera_to_world) {
  auto placed = place(frame, camera_to_world);
  if (!placed) return makeError(placed.error());
  return placed->decision == SubmapDecision::Covered ? KeyFrameAdded::Covered
                                                     : KeyFrameAdded::Stored;
}

Status SubmapLearner::drain() {
  std::shared_ptr<OnlineLearner> active;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    freeze_cv_.wait(lock, [&] { return pending_.empty(); });
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
    if (model.frozen && s < static_cast<int>(frozen_.size())) {
      model.relocalizer = frozen_[static_cast<std::size_t>(s)].relocalizer;
      model.file = frozen_[static_cast<std::size_t>(s)].model_id;
    } else if (!model.frozen)
      model.relocalizer = active_ ? active_->current() : nullptr;
    if (model.relocalizer) out.push_back(std::move(model));
  }
  return out;
}

std::vector<Place> SubmapLearner::places() const {
  return submapPlaces(models(), names_.place, names_.map_frame);
}

LearnerSummary SubmapLearner::summary() const {
  const SubmapStatus s = status();
  return {s.keyframes_added,
          s.keyframes_added - s.active.keyframes_stored + s.active.keyframes_learned,
          s.active.backlog, s.last_error};
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
    status.freezes_pending = static_cast<int>(pending_.size());
    status.freezing = status.freezes_pending > 0;
    status.freezes_pending_most = pending_most_;
    status.freeze_waits = freeze_waits_;
    status.freeze_wait_seconds = freeze_wait_seconds_;
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
