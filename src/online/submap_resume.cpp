#include "relocalizer/online/submap_resume.h"

#include <algorithm>
#include <filesystem>

#include "relocalizer/online/submap_archive.h"

namespace relocalizer {

namespace {

Expected<ResumedSubmaps> readResumedFolder(const std::string& folder,
                                           const LearningParams& learning,
                                           const RelocalizerParams& params,
                                           OnlineLearner::Mode mode, const std::string& map_frame) {
  auto manifest = readSubmapManifest(folder);
  if (!manifest) return makeError(manifest.error());
  const int count = manifest->submaps.empty() ? 0 : manifest->submaps.back().index + 1;
  ResumedSubmaps r;
  r.key_frames.resize(static_cast<std::size_t>(count));
  r.frozen.resize(static_cast<std::size_t>(count));
  r.folder = folder;
  for (const SubmapEntry& e : manifest->submaps)
    for (const SubmapKeyFrame& k : e.keyframe_poses) r.next_id = std::max(r.next_id, k.id + 1);
  ReadSubmaps read = readSubmaps(
      folder, *manifest, learning.max_keyframes, learnedModelParams(learning, params), params,
      [&](const SubmapEntry& e) -> Expected<std::string> {
        auto learner = continueActiveSubmap(folder, e, learning, params, mode);
        if (!learner) return makeError(learner.error());
        // The index must list the store's key frames in the store's order (the
        // next freeze finds its seeds by position). They are the manifest's
        // unless a save was cut between the active's files and the manifest.
        const std::vector<KeyFrameStore::Entry> stored = (*learner)->keyFrames();
        std::vector<SubmapKeyFrame>& slot = r.key_frames[static_cast<std::size_t>(e.index)];
        if (stored.size() == e.keyframe_poses.size()) {
          slot = e.keyframe_poses;
        } else {
          for (const KeyFrameStore::Entry& k : stored) slot.push_back({r.next_id++, k->pose});
        }
        r.active = std::move(*learner);
        r.active_index = e.index;
        return r.active->status().last_error;
      });
  if (manifest->map_frame != map_frame)
    r.warnings.push_back(submapManifestPath(folder) + ": the set was learned in map frame " +
                         manifest->map_frame + ", continued in " + map_frame);
  r.warnings.insert(r.warnings.end(), read.warnings.begin(), read.warnings.end());
  for (const SubmapEntry& e : manifest->submaps) {
    const std::size_t i = static_cast<std::size_t>(e.index);
    if (!read.frozen[i]) continue;
    r.frozen[i] = {std::move(read.frozen[i]), true, e.model_id};
    r.key_frames[i] = e.keyframe_poses;
  }
  return r;
}

Expected<ResumedSubmaps> readResumedModelFile(const std::string& path,
                                              const LearningParams& learning,
                                              const RelocalizerParams& params,
                                              OnlineLearner::Mode mode) {
  ResumedSubmaps r;
  // `train` writes a model alone; a learner saves its key frames beside it.
  if (std::error_code ec; !std::filesystem::exists(keyFramesPath(path), ec)) {
    // Served as a model made by `train` is served (the surface gate on): its
    // surface is that of the survey, not of a few key frames.
    auto surveyed = loadSurveyedModel(path, params);
    if (!surveyed) return makeError(surveyed.error());
    if ((*surveyed)->model().surface.empty())
      r.warnings.push_back(path +
                           " has no surface (trained with surface.enabled false): nothing tells "
                           "which key frames it already knows, so every one is learned into "
                           "submaps beside it");
    r.frozen.push_back({std::move(*surveyed), false, {}});
    r.key_frames.emplace_back();
    return r;
  }
  auto learner = std::make_shared<OnlineLearner>(learning, params, mode);
  if (Status resumed = learner->resume(path); !resumed) return makeError(resumed.error());
  r.key_frames.emplace_back();
  for (const KeyFrameStore::Entry& k : learner->keyFrames())
    r.key_frames[0].push_back({r.next_id++, k->pose});
  r.frozen.emplace_back();
  r.active_index = 0;
  if (std::string note = learner->status().last_error; !note.empty())
    r.warnings.push_back(std::move(note));
  r.active = std::move(learner);
  return r;
}

}  // namespace

Expected<ResumedSubmaps> readResumedSubmaps(const std::string& path, const LearningParams& learning,
                                            const RelocalizerParams& params,
                                            OnlineLearner::Mode mode,
                                            const std::string& map_frame) {
  if (std::error_code ec; std::filesystem::is_directory(path, ec))
    return readResumedFolder(path, learning, params, mode, map_frame);
  return readResumedModelFile(path, learning, params, mode);
}

}  // namespace relocalizer
