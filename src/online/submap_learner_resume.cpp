#include "relocalizer/online/submap_learner.h"
// SubmapLearner's resume(): a saved set of submaps, a place learned before
// submaps, or a model made by `train` (a surveyed submap) continued.
#include <filesystem>

#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/submap_archive.h"

namespace relocalizer {

Expected<std::vector<std::string>> SubmapLearner::resume(const std::string& folder) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (next_id_ != 0 || index_.submapCount() != 0)
    return makeError("resume() must come before the first key frame, and only once");
  if (std::error_code ec; !std::filesystem::is_directory(folder, ec))
    return resumeModelFile(folder);
  auto manifest = readSubmapManifest(folder);
  if (!manifest) return makeError(manifest.error());
  const int count = manifest->submaps.empty() ? 0 : manifest->submaps.back().index + 1;
  std::vector<std::vector<SubmapKeyFrame>> slots(static_cast<std::size_t>(count));
  std::shared_ptr<OnlineLearner> active;
  int active_index = -1;
  std::int64_t next_id = 0;
  for (const SubmapEntry& e : manifest->submaps)
    for (const SubmapKeyFrame& k : e.keyframe_poses) next_id = std::max(next_id, k.id + 1);
  ReadSubmaps read = readSubmaps(
      folder, *manifest, learning_.max_keyframes,
      learnedModelParams(learning_, relocalizer_params_), relocalizer_params_,
      [&](const SubmapEntry& e) -> Expected<std::string> {
        auto learner = continueActiveSubmap(folder, e, learning_, relocalizer_params_, mode_);
        if (!learner) return makeError(learner.error());
        // The index must list the store's key frames in the store's order (the
        // next freeze finds its seeds by position). They are the manifest's
        // unless a save was cut between the active's files and the manifest.
        const std::vector<KeyFrameStore::Entry> stored = (*learner)->keyFrames();
        std::vector<SubmapKeyFrame>& slot = slots[static_cast<std::size_t>(e.index)];
        if (stored.size() == e.keyframe_poses.size()) {
          slot = e.keyframe_poses;
        } else {
          for (const KeyFrameStore::Entry& k : stored) slot.push_back({next_id++, k->pose});
        }
        active = std::move(*learner);
        active_index = e.index;
        return active->status().last_error;
      });
  std::vector<std::string> warnings;
  if (manifest->map_frame != names_.map_frame)
    warnings.push_back(submapManifestPath(folder) + ": the set was learned in map frame " +
                       manifest->map_frame + ", continued in " + names_.map_frame);
  warnings.insert(warnings.end(), read.warnings.begin(), read.warnings.end());
  frozen_.assign(static_cast<std::size_t>(count), Frozen{});
  for (const SubmapEntry& e : manifest->submaps) {
    const std::size_t i = static_cast<std::size_t>(e.index);
    if (!read.frozen[i]) continue;
    frozen_[i] = {std::move(read.frozen[i]), {}, true, e.model_id};
    slots[i] = e.keyframe_poses;
  }
  for (const auto& slot : slots) added_ += static_cast<int>(slot.size());
  index_.restore(std::move(slots), active_index);
  active_ = std::move(active);
  next_id_ = next_id;
  folder_ = folder;
  warnings_ = warnings;
  return warnings;
}

Expected<std::vector<std::string>> SubmapLearner::resumeModelFile(const std::string& path) {
  // `train` writes a model alone; a learner saves its key frames beside it.
  if (std::error_code ec; !std::filesystem::exists(keyFramesPath(path), ec))
    return resumeSurveyedModel(path);
  auto learner = std::make_shared<OnlineLearner>(learning_, relocalizer_params_, mode_);
  if (Status resumed = learner->resume(path); !resumed) return makeError(resumed.error());
  std::vector<SubmapKeyFrame> key_frames;
  for (const KeyFrameStore::Entry& k : learner->keyFrames())
    key_frames.push_back({next_id_++, k->pose});
  added_ = static_cast<int>(key_frames.size());
  index_.restore({std::move(key_frames)}, 0);
  active_ = std::move(learner);
  warnings_.clear();
  if (std::string note = active_->status().last_error; !note.empty())
    warnings_.push_back(std::move(note));
  return warnings_;
}

Expected<std::vector<std::string>> SubmapLearner::resumeSurveyedModel(const std::string& path) {
  // Served as a model made by `train` is served (the surface gate on): its
  // surface is that of the survey, not of a few key frames.
  auto surveyed = loadSurveyedModel(path, relocalizer_params_);
  if (!surveyed) return makeError(surveyed.error());
  std::vector<std::string> warnings;
  if ((*surveyed)->model().surface.empty())
    warnings.push_back(path +
                       " has no surface (trained with surface.enabled false): nothing tells which "
                       "key frames it already knows, so every one is learned into submaps beside "
                       "it");
  // Not trained again: it has no key frames to be trained on. The first save
  // writes it into the set as it is (writeSet).
  frozen_.assign(1, Frozen{std::move(*surveyed), {}, false, {}});
  index_.restore({{}}, -1);
  warnings_ = warnings;
  return warnings;
}

}  // namespace relocalizer
