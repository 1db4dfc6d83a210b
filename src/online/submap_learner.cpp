#include "relocalizer/online/submap_learner.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <stdexcept>

#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/learned_places.h"
#include "relocalizer/online/place_change.h"
#include "relocalizer/online/submap_archive.h"
#include "relocalizer/online/submap_resume.h"

namespace relocalizer {

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
    freezer_ = std::make_unique<SerialWorker>();
    retirer_ = std::make_unique<SerialWorker>();
  }
}

SubmapLearner::~SubmapLearner() {
  freezer_.reset();  // after the freezes handed over: each submap has its final model and files
  retirer_.reset();
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
  const bool write = retrained && model && !folder.empty();
  Expected<ModelFileId> written = ModelFileId{};
  if (write) written = writeSubmapPair(folder, p.index, *model, p.key_frames);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Frozen& f = frozen_[static_cast<std::size_t>(p.index)];
    // A submap that fails its last retrain keeps the model it had.
    f.relocalizer = model;
    if (write && written) {
      f.written = true;
      f.model_id = *written;
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
      return makeError(written.error());
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

Status SubmapLearner::freezeFront() {
  std::unique_lock<std::mutex> lock(mutex_);
  const Pending next = pending_.front();
  lock.unlock();
  const Status frozen = freeze(next);
  lock.lock();
  pending_.pop_front();
  freeze_cv_.notify_all();
  return frozen;
}

Expected<SubmapPlacement> SubmapLearner::place(const RgbdFrame& frame,
                                               const Pose& camera_to_world) {
  // Checked before the index records it: what the store refuses must not be
  // placed (only an encoder failure is left, which the store reports).
  if (const std::string why = frameValidationError(frame); !why.empty())
    return makeError("key frame " + std::to_string(frame.id) + ": " + why);
  const ViewKnowledge known = viewKnowledge(*this, frame, camera_to_world);
  const bool may_cover = known != ViewKnowledge::kChanged;
  SubmapPlacement placement;
  std::shared_ptr<OnlineLearner> active;
  bool freeze_inline = false;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    if (known == ViewKnowledge::kSurveyed) {
      placement.decision = SubmapDecision::Covered;
      ++covered_;
      return placement;
    }
    // A new submap waits for room in the queue, and for a save waiting for
    // the queue (either mode: an Inline freeze is pending while it runs, and
    // a save meanwhile would leave it out). Only this thread changes the
    // index, so the decision (and may_cover) holds across the wait.
    const auto room = [&] {
      return saves_waiting_ == 0 && static_cast<int>(pending_.size()) < kMaxPendingFreezes;
    };
    if (active_ && !room()) {
      const SubmapDecision next = index_.decide(camera_to_world, may_cover);
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
    placement = index_.place(next_id_++, camera_to_world, may_cover);
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
          // Stopping the learner aborts a retrain it runs: off this thread.
          retirer_->post([retired = std::move(active_)]() mutable { retired.reset(); });
          // A failure is in status().last_error and warnings().
          freezer_->post([this] { (void)freezeFront(); });
        } else {
          freeze_inline = true;
        }
      }
      active_ = std::make_shared<OnlineLearner>(learning_, relocalizer_params_, mode_);
      if (Status seeded = active_->seed(std::move(seeds)); !seeded)
        return makeError(seeded.error());
    }
    active = active_;
  }
  // Inline, outside the lock: a retrain takes seconds, and models() may be read meanwhile. A
  // submap that fails its last retrain (or its write) keeps the model it had: the failure is
  // the caller's to report, the run goes on with the new submap, which the index has started.
  const Status frozen = freeze_inline ? freezeFront() : okStatus();
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

// --- The set on disk (submap_archive.h) ---------------------------------------
Status SubmapLearner::writeManifest(const std::string& folder, int finished) {
  std::vector<FileReplacement> manifest_file;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    SubmapManifest manifest =
        submapManifestHead(names_.place, names_.map_frame, learning_, submap_params_);
    for (int s = 0; s < static_cast<int>(frozen_.size()); ++s) {
      const Frozen& f = frozen_[static_cast<std::size_t>(s)];
      if (s != index_.active() && (s == finished || !pending(s)) && f.relocalizer && f.written)
        manifest.submaps.push_back(
            frozenSubmapEntry(names_.place, s, index_.keyFrames(s), f.model_id));
    }
    manifest_file.push_back(submapManifestReplacement(folder, manifest));
  }
  return replaceFiles(manifest_file);
}

Status SubmapLearner::writeSet(const std::string& folder, bool with_active, bool adopt) {
  if (Status ready = prepareSubmapFolder(folder); !ready) return ready;
  std::error_code ec;
  const bool working = !folder_.empty() && std::filesystem::equivalent(folder, folder_, ec);

  SubmapManifest manifest =
      submapManifestHead(names_.place, names_.map_frame, learning_, submap_params_);
  std::vector<int> written_now;
  for (int s = 0; s < static_cast<int>(frozen_.size()); ++s) {
    Frozen& f = frozen_[static_cast<std::size_t>(s)];
    if (s == index_.active() || pending(s) || !f.relocalizer) continue;
    if (!f.written) {
      auto written = writeSubmapPair(folder, s, *f.relocalizer, f.key_frames);
      if (!written) return makeError(written.error());
      f.model_id = *written;
      written_now.push_back(s);
    } else if (!working) {
      if (Status copied = copySubmapPair(folder_, folder, s, *f.relocalizer, f.model_id, warnings_);
          !copied)
        return copied;
    }
    manifest.submaps.push_back(frozenSubmapEntry(names_.place, s, index_.keyFrames(s), f.model_id));
  }

  std::vector<FileReplacement> last;
  if (with_active && active_) {
    const int s = index_.active();
    manifest.active = s;
    manifest.submaps.push_back(
        activeSubmapFiles(folder, names_.place, s, index_.keyFrames(s), *active_, last));
  }
  if (with_active && manifest.submaps.empty())
    return makeError(folder + ": nothing to save yet: no submap has been learned");
  last.push_back(submapManifestReplacement(folder, manifest));
  if (Status done = replaceFiles(last); !done) return done;

  if (!(adopt || working || folder_.empty())) return okStatus();
  folder_ = folder;
  for (int s : written_now) {
    Frozen& f = frozen_[static_cast<std::size_t>(s)];
    f.written = true;
    f.key_frames.clear();
    f.key_frames.shrink_to_fit();
  }
  return okStatus();
}

Status SubmapLearner::useFolder(const std::string& folder) {
  // Pending freezes are not waited for: each writes its files into the
  // working folder of when it ends.
  std::lock_guard<std::mutex> files(files_mutex_);
  std::lock_guard<std::mutex> lock(mutex_);
  if (Status ready = prepareSubmapFolder(folder); !ready) return ready;
  std::error_code ec;
  const bool held = std::any_of(frozen_.begin(), frozen_.end(),
                                [](const Frozen& f) { return f.relocalizer && !f.written; });
  const bool moved = !folder_.empty() && !std::filesystem::equivalent(folder, folder_, ec);
  if (held || moved) return writeSet(folder, false, true);
  folder_ = folder;
  return okStatus();
}

std::string SubmapLearner::workingFolder() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return folder_;
}

std::vector<std::string> SubmapLearner::warnings() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return warnings_;
}

Status SubmapLearner::save(const std::string& folder) {
  {
    // A submap being frozen is written with its final model, once: the save
    // waits for the pending freezes, and no new one is handed over until it
    // has written.
    std::unique_lock<std::mutex> lock(mutex_);
    ++saves_waiting_;
    freeze_cv_.wait(lock, [&] { return pending_.empty(); });
  }
  Status saved = okStatus();
  {
    std::lock_guard<std::mutex> files(files_mutex_);
    std::lock_guard<std::mutex> lock(mutex_);
    saved = writeSet(folder, true, false);
    --saves_waiting_;
  }
  freeze_cv_.notify_all();
  return saved;
}

Expected<std::vector<std::string>> SubmapLearner::resume(const std::string& path) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (next_id_ != 0 || index_.submapCount() != 0)
    return makeError("resume() must come before the first key frame, and only once");
  auto resumed = readResumedSubmaps(path, learning_, relocalizer_params_, mode_, names_.map_frame);
  if (!resumed) return makeError(resumed.error());
  frozen_.clear();
  for (ResumedFrozen& f : resumed->frozen)
    frozen_.push_back({std::move(f.relocalizer), {}, f.written, f.model_id});
  for (const auto& slot : resumed->key_frames) added_ += static_cast<int>(slot.size());
  index_.restore(std::move(resumed->key_frames), resumed->active_index);
  active_ = std::move(resumed->active);
  next_id_ = resumed->next_id;
  folder_ = resumed->folder;
  warnings_ = resumed->warnings;
  return warnings_;
}

std::vector<SubmapModel> SubmapLearner::models(bool current_place) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<SubmapModel> out;
  for (int s = current_place ? index_.firstOfPlace() : 0; s < index_.submapCount(); ++s) {
    SubmapModel model;
    model.index = s;
    model.frozen = index_.frozen(s);
    model.keyframes = static_cast<int>(index_.keyFrames(s).size());
    model.part = s >= index_.firstOfPlace() ? 1 : 0;
    if (model.frozen && s < static_cast<int>(frozen_.size())) {
      model.relocalizer = frozen_[static_cast<std::size_t>(s)].relocalizer;
      model.file = frozen_[static_cast<std::size_t>(s)].model_id;
    } else if (!model.frozen)
      model.relocalizer = active_ ? active_->current() : nullptr;
    if (model.relocalizer) out.push_back(std::move(model));
  }
  return out;
}

std::vector<Place> SubmapLearner::places() const { return learnedPlaces(models(), names_); }
std::vector<Place> SubmapLearner::currentPlaces() const {
  return learnedPlaces(models(true), names_);
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
