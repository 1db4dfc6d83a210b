// SubmapLearner's folder: writing the set (submap_folder.h) and continuing it.
// The learning itself is in submap_learner.cpp.

#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <set>

#include "relocalizer/core/file_io.h"
#include "relocalizer/core/version.h"
#include "relocalizer/online/submap_folder.h"
#include "relocalizer/online/submap_learner.h"

namespace relocalizer {
namespace {

namespace fs = std::filesystem;

std::string inFolder(const std::string& folder, const std::string& name) {
  return (fs::path(folder) / name).string();
}

// A frozen submap's model as the manifest names it; errors say why not.
Expected<std::shared_ptr<const Relocalizer>> loadSubmapModel(const std::string& path,
                                                             const ModelFileId& expected,
                                                             const RelocalizerParams& params) {
  try {
    auto bytes = readRegularFile(path, modelFileFormat("submap model file"));
    if (!bytes) return makeError(bytes.error());
    const ModelFileId found = modelFileId(*bytes);
    if (found != expected)
      return makeError(path + " is not the model the manifest names (" +
                       std::to_string(found.size) + " bytes, CRC " + std::to_string(found.crc) +
                       "; the manifest names " + std::to_string(expected.size) + " bytes, CRC " +
                       std::to_string(expected.crc) + ")");
    auto model = deserializeModel(bytes->data(), bytes->size(), path);
    if (!model) return makeError(model.error());
    auto relocalizer = std::make_shared<const Relocalizer>(std::move(*model), params);
    if (const std::string why = relocalizer->validationError(); !why.empty())
      return makeError(path + ": " + why);
    return std::shared_ptr<const Relocalizer>(std::move(relocalizer));
  } catch (const std::exception& e) {
    // Whatever a damaged file makes the loader throw (std::bad_alloc on a
    // corrupt size) skips this submap only.
    return makeError(path + ": cannot be loaded: " + loadFailureReason(e));
  }
}

// Why a file the manifest names is not read: a symbolic link, which could
// reach any file outside the set's folder; empty when it is not one.
std::string linkError(const std::string& folder, const std::string& name) {
  struct stat info = {};
  const std::string path = inFolder(folder, name);
  if (!name.empty() && ::lstat(path.c_str(), &info) == 0 && S_ISLNK(info.st_mode))
    return path + " is a symbolic link: not followed out of the folder";
  return {};
}

// Files the manifest does not name: a freeze cut short before its manifest,
// or a submap skipped by an earlier resume. Never read; a later freeze of
// that index replaces them. A warning each.
std::vector<std::string> unnamedFiles(const std::string& folder, const SubmapManifest& manifest) {
  std::set<std::string> named;
  for (const SubmapEntry& e : manifest.submaps) named.insert(e.model);
  std::vector<std::string> orphans, warnings;
  try {
    for (const fs::directory_entry& file : fs::directory_iterator(folder)) {
      const std::string name = file.path().filename().string();
      if (name.rfind("submap-", 0) == 0 && file.path().extension() == ".model" &&
          !named.count(name))
        orphans.push_back(name);
    }
  } catch (const fs::filesystem_error& e) {
    warnings.push_back(folder + ": cannot list the folder's other files: " + e.code().message());
  }
  std::sort(orphans.begin(), orphans.end());
  for (const std::string& name : orphans)
    warnings.push_back(inFolder(folder, name) + " is not named by " + kSubmapManifestName +
                       ": ignored");
  return warnings;
}

// `folder` made ready to hold the set: created if need be, refused when it
// is something else (a file, a pipe: never replaced) or holds someone else's
// manifest.json (not ours to fill; checked before any submap file is written).
Status prepareFolder(const std::string& folder) {
  std::error_code ec;
  if (fs::exists(folder, ec) && !fs::is_directory(folder, ec))
    return makeError(folder +
                     ": is not a folder: a learned set is saved as one folder (manifest.json and "
                     "a model and key-frame file per submap); a model file saved before submaps "
                     "is continued, not replaced");
  fs::create_directories(folder, ec);
  if (ec) return makeError(folder + ": cannot create the folder: " + systemErrorText(ec.value()));
  if (const std::string why = replaceableError(submapManifestPath(folder), kSubmapManifestMagic,
                                               "learned-submaps manifest");
      !why.empty())
    return makeError(why);
  return okStatus();
}

}  // namespace

Status SubmapLearner::writeFrozenPair(const std::string& folder, int index,
                                      const Relocalizer& model,
                                      const std::vector<KeyFrameStore::Entry>& key_frames,
                                      ModelFileId& model_id) const {
  const std::string model_name = submapFileName(index);
  std::vector<uint8_t> bytes = serializeModel(model.model());
  model_id = modelFileId(bytes);
  std::vector<FileReplacement> pair;
  pair.push_back(keyFrameFileReplacement(inFolder(folder, keyFramesPath(model_name)),
                                         serializeKeyFrames(key_frames, model_id)));
  pair.push_back(modelFileReplacement(inFolder(folder, model_name), std::move(bytes)));
  return replaceFiles(pair);
}

SubmapManifest SubmapLearner::manifestHead() const {
  SubmapManifest manifest;
  manifest.place_name = names_.place;
  manifest.map_frame = names_.map_frame;
  manifest.software_version = kSoftwareVersion;
  manifest.min_motion = learning_.min_motion;
  manifest.max_keyframes = learning_.max_keyframes;
  manifest.submap_params = submap_params_;
  return manifest;
}

SubmapEntry SubmapLearner::frozenEntry(int s) const {
  SubmapEntry entry;
  entry.index = s;
  entry.name = submapPlaceName(names_.place, s);
  entry.model = submapFileName(s);
  entry.keyframes = keyFramesPath(entry.model);
  entry.keyframe_poses = index_.keyFrames(s);
  entry.model_id = frozen_[static_cast<std::size_t>(s)].model_id;
  return entry;
}

Status SubmapLearner::writeManifest(const std::string& folder, int finished) {
  std::vector<FileReplacement> manifest_file;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    SubmapManifest manifest = manifestHead();
    for (int s = 0; s < static_cast<int>(frozen_.size()); ++s) {
      const Frozen& f = frozen_[static_cast<std::size_t>(s)];
      if (s != index_.active() && (s == finished || !pending(s)) && f.relocalizer && f.written)
        manifest.submaps.push_back(frozenEntry(s));
    }
    manifest_file.push_back(submapManifestReplacement(folder, manifest));
  }
  return replaceFiles(manifest_file);
}

Status SubmapLearner::writeSet(const std::string& folder, bool with_active, bool adopt) {
  if (Status ready = prepareFolder(folder); !ready) return ready;
  std::error_code ec;
  const bool working = !folder_.empty() && fs::equivalent(folder, folder_, ec);

  SubmapManifest manifest = manifestHead();
  std::vector<int> written_now;
  for (int s = 0; s < static_cast<int>(frozen_.size()); ++s) {
    Frozen& f = frozen_[static_cast<std::size_t>(s)];
    if (s == index_.active() || pending(s) || !f.relocalizer) continue;
    const std::string model_name = submapFileName(s);
    const std::string model_path = inFolder(folder, model_name);
    const std::string keyframes_path = inFolder(folder, keyFramesPath(model_name));
    if (!f.written) {
      if (Status done = writeFrozenPair(folder, s, *f.relocalizer, f.key_frames, f.model_id); !done)
        return done;
      written_now.push_back(s);
    } else if (!working) {
      // Frozen files never change, so one already in `folder` (an earlier
      // save there) is left as it is.
      auto there = readRegularFile(model_path, modelFileFormat("submap model file"));
      if (!there || modelFileId(*there) != f.model_id) {
        std::vector<FileReplacement> pair;
        auto keyframes =
            readRegularFile(inFolder(folder_, keyFramesPath(model_name)), keyFrameFileFormat());
        if (keyframes)
          pair.push_back(keyFrameFileReplacement(keyframes_path, std::move(*keyframes)));
        else
          warnings_.push_back(keyframes.error() + ": not copied to " + folder + " (submap " +
                              std::to_string(s) + " still answers from its model)");
        pair.push_back(modelFileReplacement(model_path, serializeModel(f.relocalizer->model())));
        if (Status done = replaceFiles(pair); !done) return done;
      }
    }
    manifest.submaps.push_back(frozenEntry(s));
  }

  std::vector<FileReplacement> last;
  if (with_active && active_) {
    const int s = index_.active();
    SubmapEntry entry;
    entry.index = s;
    entry.name = submapPlaceName(names_.place, s);
    entry.frozen = false;
    entry.keyframes = keyFramesPath(submapFileName(s));
    entry.keyframe_poses = index_.keyFrames(s);
    // The model first: the key frames then include every one it learned
    // (the active's store only grows).
    const std::shared_ptr<const Relocalizer> model = active_->current();
    std::vector<uint8_t> model_bytes;
    if (model) {
      model_bytes = serializeModel(model->model());
      entry.model = submapFileName(s);
      entry.model_id = modelFileId(model_bytes);
    }
    last.push_back(
        keyFrameFileReplacement(inFolder(folder, entry.keyframes),
                                serializeKeyFrames(active_->keyFrames(), entry.model_id)));
    if (model)
      last.push_back(modelFileReplacement(inFolder(folder, entry.model), std::move(model_bytes)));
    manifest.active = s;
    manifest.submaps.push_back(std::move(entry));
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
  if (Status ready = prepareFolder(folder); !ready) return ready;
  std::error_code ec;
  const bool held = std::any_of(frozen_.begin(), frozen_.end(),
                                [](const Frozen& f) { return f.relocalizer && !f.written; });
  const bool moved = !folder_.empty() && !fs::equivalent(folder, folder_, ec);
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

Expected<std::vector<std::string>> SubmapLearner::resume(const std::string& folder) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (next_id_ != 0 || index_.submapCount() != 0)
    return makeError("resume() must come before the first key frame, and only once");
  if (std::error_code ec; !fs::is_directory(folder, ec)) {
    if (Status resumed = resumeModelFile(folder); !resumed) return makeError(resumed.error());
    std::vector<std::string> notes;
    if (const std::string note = active_->status().last_error; !note.empty()) notes.push_back(note);
    warnings_ = notes;
    return notes;
  }
  auto manifest = readSubmapManifest(folder);
  if (!manifest) return makeError(manifest.error());
  std::vector<std::string> warnings;
  if (manifest->map_frame != names_.map_frame)
    warnings.push_back(submapManifestPath(folder) + ": the set was learned in map frame " +
                       manifest->map_frame + ", continued in " + names_.map_frame);
  // Indices are at most kMaxSubmapIndex (readSubmapManifest): the slots by
  // index cost a few MB at worst.
  const int count = manifest->submaps.empty() ? 0 : manifest->submaps.back().index + 1;
  std::vector<std::vector<SubmapKeyFrame>> slots(static_cast<std::size_t>(count));
  std::vector<Frozen> frozen(static_cast<std::size_t>(count));
  std::shared_ptr<OnlineLearner> active;
  int active_index = -1;
  std::int64_t next_id = 0;
  for (const SubmapEntry& e : manifest->submaps)
    for (const SubmapKeyFrame& k : e.keyframe_poses) next_id = std::max(next_id, k.id + 1);
  const RelocalizerParams served = learnedModelParams(learning_, relocalizer_params_);
  const std::string skipped = "; skipped: its area is learned again when the camera returns";
  for (const SubmapEntry& e : manifest->submaps) {
    const std::string name = "submap " + std::to_string(e.index) + ": ";
    const std::string model_path = inFolder(folder, e.model);
    const std::string keyframes_path = inFolder(folder, e.keyframes);
    const std::size_t i = static_cast<std::size_t>(e.index);
    std::string why = linkError(folder, e.model);
    if (why.empty()) why = linkError(folder, e.keyframes);
    if (!why.empty()) {
      warnings.push_back(name + why + skipped);
      continue;
    }
    bool as_frozen = e.frozen;
    // Its store would evict to fit, and the index would no longer line up with it.
    if (!e.frozen && !e.model.empty() &&
        static_cast<int>(e.keyframe_poses.size()) > learning_.max_keyframes) {
      warnings.push_back(name + "holds " + std::to_string(e.keyframe_poses.size()) +
                         " key frames, more than max_keyframes " +
                         std::to_string(learning_.max_keyframes) + ": continued as frozen");
      as_frozen = true;
    }
    if (as_frozen) {
      auto loaded = loadSubmapModel(model_path, e.model_id, served);
      if (!loaded) {
        warnings.push_back(name + loaded.error() + skipped);
        continue;
      }
      frozen[i] = {std::move(*loaded), {}, true, e.model_id};
      slots[i] = e.keyframe_poses;
      if (std::error_code ec; !fs::exists(keyframes_path, ec))
        warnings.push_back(name + keyframes_path +
                           " is missing: the submap still answers and covers its area");
      continue;
    }
    auto learner = std::make_shared<OnlineLearner>(learning_, relocalizer_params_, mode_);
    Status resumed = okStatus();
    if (!e.model.empty()) {
      resumed = learner->resume(model_path);
    } else if (auto saved = loadKeyFrames(keyframes_path); !saved) {
      resumed = makeError(saved.error());
    } else {
      // Saved before its first retrain: its key frames alone, learned at the next drain.
      std::vector<KeyFrameStore::Entry> entries;
      for (StoredKeyFrame& k : saved->key_frames)
        entries.push_back(std::make_shared<const StoredKeyFrame>(std::move(k)));
      resumed = learner->seed(std::move(entries));
    }
    if (!resumed) {
      warnings.push_back(name + resumed.error() + skipped);
      continue;
    }
    if (const std::string note = learner->status().last_error; !note.empty())
      warnings.push_back(name + note);
    // The index must list the store's key frames in the store's order (the
    // next freeze finds its seeds by position). They are the manifest's unless
    // a save was cut between the active's files and the manifest.
    const std::vector<KeyFrameStore::Entry> stored = learner->keyFrames();
    if (stored.size() == e.keyframe_poses.size()) {
      slots[i] = e.keyframe_poses;
    } else {
      for (const KeyFrameStore::Entry& k : stored) slots[i].push_back({next_id++, k->pose});
    }
    active = std::move(learner);
    active_index = e.index;
  }
  for (std::string& orphan : unnamedFiles(folder, *manifest)) warnings.push_back(std::move(orphan));
  for (const auto& slot : slots) added_ += static_cast<int>(slot.size());
  index_.restore(std::move(slots), active_index);
  frozen_ = std::move(frozen);
  active_ = std::move(active);
  next_id_ = next_id;
  folder_ = folder;
  warnings_ = warnings;
  return warnings;
}

Expected<SavedSubmaps> loadSavedSubmaps(const std::string& folder, const std::string& group,
                                        const std::string& map_frame,
                                        const RelocalizerParams& params) {
  auto manifest = readSubmapManifest(folder);
  if (!manifest) return makeError(manifest.error());
  LearningParams learning;
  // The saved settings, so that the active submap loads as it was learned.
  learning.max_keyframes = manifest->max_keyframes;
  learning.first_retrain = 1;
  std::string why = learningParamsError(learning);
  if (why.empty()) why = submapParamsError(manifest->submap_params, learning.max_keyframes);
  if (!why.empty()) return makeError(submapManifestPath(folder) + ": " + why);
  SubmapLearner submaps(learning, manifest->submap_params, params,
                        {manifest->place_name, manifest->map_frame});
  Expected<std::vector<std::string>> resumed = makeError("not loaded");
  try {
    resumed = submaps.resume(folder);
  } catch (const std::exception& e) {
    // A set that cannot be loaded is an error of this folder, never the end
    // of the node or tool that asked for it.
    return makeError(folder + ": cannot be loaded: " + loadFailureReason(e));
  }
  if (!resumed) return makeError(resumed.error());
  SavedSubmaps saved;
  saved.saved_map_frame = manifest->map_frame;
  saved.warnings = std::move(*resumed);
  const std::vector<SubmapModel> models = submaps.models();
  saved.places = submapPlaces(models, group, map_frame);
  // Listings and logs name each place's file; its contents are its identity
  // (one folder loaded twice, by a copy, a link or another spelling, is
  // refused as one model file twice is: PlaceSet). A frozen submap's is the
  // manifest's, checked as it loaded; the active's is read here, and one
  // saved before its first model is known by its key frames.
  for (std::size_t i = 0; i < models.size(); ++i) {
    Place& place = saved.places[i];
    place.source = inFolder(folder, submapFileName(models[i].index));
    if (place.model_id.empty()) place.model_id = modelFileIdentity(place.source);
    if (place.model_id.empty())
      if (const std::string id = modelFileIdentity(keyFramesPath(place.source)); !id.empty())
        place.model_id = "key frames, " + id;
  }
  if (saved.places.empty()) {
    std::string reasons;
    for (const std::string& warning : saved.warnings) reasons += "; " + warning;
    return makeError(folder + ": no submap of the saved set could be loaded" + reasons);
  }
  return saved;
}

}  // namespace relocalizer
