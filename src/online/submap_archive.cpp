#include "relocalizer/online/submap_archive.h"

#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <set>

#include "relocalizer/core/version.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/learned_places.h"

namespace relocalizer {
namespace {

namespace fs = std::filesystem;

// A submap's model served with `params`, unless `refusal` says why its file
// (identified by its contents) is not the one it must be. Errors say why not.
using ModelFileRefusal = std::function<std::string(const ModelFileId& found)>;
Expected<std::shared_ptr<const Relocalizer>> loadSubmapModel(const std::string& path,
                                                             const ModelFileRefusal& refusal,
                                                             const RelocalizerParams& params) {
  try {
    auto bytes = readRegularFile(path, modelFileFormat("submap model file"));
    if (!bytes) return makeError(bytes.error());
    if (const std::string why = refusal(modelFileId(*bytes)); !why.empty())
      return makeError(path + " is not the model " + why);
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
  const std::string path = inSubmapFolder(folder, name);
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
    warnings.push_back(
        folder + ": cannot list the folder's other files: " + systemErrorText(e.code().value()));
  }
  std::sort(orphans.begin(), orphans.end());
  for (const std::string& name : orphans)
    warnings.push_back(inSubmapFolder(folder, name) + " is not named by " + kSubmapManifestName +
                       ": ignored");
  return warnings;
}

// The active submap's model as a learner continuing it would serve it: the
// model and its key frames are one unit (OnlineLearner::resume), so the model
// answers only beside the key frames it was saved with. Null when it has no
// model yet (saved before its first retrain: nothing to answer with).
Expected<std::shared_ptr<const Relocalizer>> readActiveSubmapModel(
    const std::string& folder, const SubmapEntry& e, const RelocalizerParams& served) {
  if (e.model.empty()) return std::shared_ptr<const Relocalizer>();
  const std::string model_path = inSubmapFolder(folder, e.model);
  const std::string key_frames_path = keyFramesPath(model_path);
  auto key_frames = loadKeyFrames(key_frames_path);
  if (!key_frames)
    return makeError("cannot answer from " + model_path +
                     " without its key frames: " + key_frames.error());
  if (key_frames->key_frames.empty())
    return makeError(key_frames_path + ": the saved submap has no key frames");
  return loadSubmapModel(
      model_path,
      [&](const ModelFileId& found) {
        return key_frames->savedWith(found)
                   ? std::string()
                   : key_frames_path + " was saved with (a save was cut between the two files)";
      },
      served);
}

// The saved set's own learning settings, so that its active submap reads as
// it was learned; errors name the manifest.
Expected<LearningParams> savedLearning(const std::string& folder, const SubmapManifest& manifest) {
  LearningParams learning;
  learning.max_keyframes = manifest.max_keyframes;
  learning.first_retrain = 1;
  std::string why = learningParamsError(learning);
  if (why.empty()) why = submapParamsError(manifest.submap_params, learning.max_keyframes);
  if (!why.empty()) return makeError(submapManifestPath(folder) + ": " + why);
  return learning;
}

Expected<SavedSubmaps> readSavedSubmaps(const std::string& folder, const SubmapManifest& manifest,
                                        const std::string& group, const std::string& map_frame,
                                        const RelocalizerParams& params) {
  auto learning = savedLearning(folder, manifest);
  if (!learning) return makeError(learning.error());
  const RelocalizerParams served = learnedModelParams(*learning, params);
  // The active submap answers with the model a learner continuing it would serve.
  std::shared_ptr<const Relocalizer> active;
  int active_index = -1;
  ReadSubmaps read = readSubmaps(folder, manifest, learning->max_keyframes, served, params,
                                 [&](const SubmapEntry& e) -> Expected<std::string> {
                                   auto model = readActiveSubmapModel(folder, e, served);
                                   if (!model) return makeError(model.error());
                                   active = std::move(*model);
                                   active_index = e.index;
                                   return std::string();
                                 });
  SavedSubmaps saved;
  saved.saved_place_name = manifest.place_name;
  saved.saved_map_frame = manifest.map_frame;
  saved.warnings = std::move(read.warnings);
  std::vector<SubmapModel> models;
  for (int s = 0; s < static_cast<int>(read.frozen.size()); ++s) {
    SubmapModel model;
    model.index = s;
    model.frozen = s != active_index;
    model.relocalizer = model.frozen ? read.frozen[static_cast<std::size_t>(s)] : active;
    for (const SubmapEntry& e : manifest.submaps)
      if (e.index == s && model.frozen) model.file = e.model_id;
    if (model.relocalizer) models.push_back(std::move(model));
  }
  saved.places = learnedPlaces(models, {group, map_frame});
  // Listings and logs name each place's file; its contents are its identity.
  // A frozen submap's is the manifest's, checked as it loaded; the active's
  // is read here.
  for (std::size_t i = 0; i < models.size(); ++i) {
    Place& place = saved.places[i];
    place.source = inSubmapFolder(folder, submapFileName(models[i].index));
    if (place.model_id.empty()) place.model_id = modelFileIdentity(place.source);
  }
  if (saved.places.empty()) {
    std::string reasons;
    for (const std::string& warning : saved.warnings) reasons += "; " + warning;
    return makeError(folder + ": no submap of the saved set could be loaded" + reasons);
  }
  return saved;
}

}  // namespace

std::string inSubmapFolder(const std::string& folder, const std::string& name) {
  return (fs::path(folder) / name).string();
}

Expected<std::shared_ptr<OnlineLearner>> continueActiveSubmap(const std::string& folder,
                                                              const SubmapEntry& e,
                                                              const LearningParams& learning,
                                                              const RelocalizerParams& params,
                                                              OnlineLearner::Mode mode) {
  auto learner = std::make_shared<OnlineLearner>(learning, params, mode);
  Status resumed = okStatus();
  if (!e.model.empty()) {
    resumed = learner->resume(inSubmapFolder(folder, e.model));
  } else if (auto saved = loadKeyFrames(inSubmapFolder(folder, e.keyframes)); !saved) {
    resumed = makeError(saved.error());
  } else {
    // Saved before its first retrain: its key frames alone, learned at the next drain.
    std::vector<KeyFrameStore::Entry> entries;
    for (StoredKeyFrame& k : saved->key_frames)
      entries.push_back(std::make_shared<const StoredKeyFrame>(std::move(k)));
    resumed = learner->seed(std::move(entries));
  }
  if (!resumed) return makeError(resumed.error());
  return learner;
}

ReadSubmaps readSubmaps(const std::string& folder, const SubmapManifest& manifest,
                        int max_keyframes, const RelocalizerParams& served,
                        const RelocalizerParams& surveyed, const ActiveSubmapReader& active) {
  // Indices are at most kMaxSubmapIndex (readSubmapManifest): the slots by
  // index cost a few MB at worst.
  const int count = manifest.submaps.empty() ? 0 : manifest.submaps.back().index + 1;
  ReadSubmaps read;
  read.frozen.resize(static_cast<std::size_t>(count));
  std::vector<std::string>& warnings = read.warnings;
  const std::string skipped = "; skipped: its area is learned again when the camera returns";
  for (const SubmapEntry& e : manifest.submaps) {
    const std::string name = "submap " + std::to_string(e.index) + ": ";
    std::string why = linkError(folder, e.model);
    if (why.empty()) why = linkError(folder, e.keyframes);
    if (!why.empty()) {
      warnings.push_back(name + why + skipped);
      continue;
    }
    bool as_frozen = e.frozen;
    // Its store would evict to fit, and the index would no longer line up with it.
    if (!e.frozen && !e.model.empty() &&
        static_cast<int>(e.keyframe_poses.size()) > max_keyframes) {
      warnings.push_back(name + "holds " + std::to_string(e.keyframe_poses.size()) +
                         " key frames, more than max_keyframes " + std::to_string(max_keyframes) +
                         ": continued as frozen");
      as_frozen = true;
    }
    if (!as_frozen) {
      auto note = active(e);
      if (!note)
        warnings.push_back(name + note.error() + skipped);
      else if (!note->empty())
        warnings.push_back(name + *note);
      continue;
    }
    const auto refusal = [&e](const ModelFileId& found) {
      if (found == e.model_id) return std::string();
      return "the manifest names (" + std::to_string(found.size) + " bytes, CRC " +
             std::to_string(found.crc) + "; the manifest names " + std::to_string(e.model_id.size) +
             " bytes, CRC " + std::to_string(e.model_id.crc) + ")";
    };
    auto loaded = loadSubmapModel(inSubmapFolder(folder, e.model), refusal,
                                  e.keyframe_poses.empty() ? surveyed : served);
    if (!loaded) {
      warnings.push_back(name + loaded.error() + skipped);
      continue;
    }
    read.frozen[static_cast<std::size_t>(e.index)] = std::move(*loaded);
    const std::string keyframes_path = inSubmapFolder(folder, e.keyframes);
    if (std::error_code ec; !fs::exists(keyframes_path, ec))
      warnings.push_back(name + keyframes_path +
                         " is missing: the submap still answers and covers its area");
  }
  for (std::string& orphan : unnamedFiles(folder, manifest)) warnings.push_back(std::move(orphan));
  return read;
}

Expected<std::shared_ptr<const Relocalizer>> loadSurveyedModel(const std::string& path,
                                                               const RelocalizerParams& params) {
  const ModelFileRefusal any_file = [](const ModelFileId&) { return std::string(); };
  return loadSubmapModel(path, any_file, params);
}

Expected<SavedSubmaps> loadSavedSubmaps(const std::string& folder, std::string group,
                                        std::string map_frame, const RelocalizerParams& params) {
  auto manifest = readSubmapManifest(folder);
  if (!manifest) return makeError(manifest.error());
  if (group.empty()) group = manifest->place_name;
  if (map_frame.empty()) map_frame = manifest->map_frame;
  try {
    return readSavedSubmaps(folder, *manifest, group, map_frame, params);
  } catch (const std::exception& e) {
    // A set that cannot be loaded is an error of this folder, never the end
    // of the node or tool that asked for it.
    return makeError(folder + ": cannot be loaded: " + loadFailureReason(e));
  }
}

Status prepareSubmapFolder(const std::string& folder) {
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

Expected<ModelFileId> writeSubmapPair(const std::string& folder, int index,
                                      const Relocalizer& model,
                                      const std::vector<KeyFrameStore::Entry>& key_frames) {
  const std::string model_name = submapFileName(index);
  std::vector<uint8_t> bytes = serializeModel(model.model());
  const ModelFileId model_id = modelFileId(bytes);
  std::vector<FileReplacement> pair;
  pair.push_back(keyFrameFileReplacement(inSubmapFolder(folder, keyFramesPath(model_name)),
                                         serializeKeyFrames(key_frames, model_id)));
  pair.push_back(modelFileReplacement(inSubmapFolder(folder, model_name), std::move(bytes)));
  if (Status written = replaceFiles(pair); !written) return makeError(written.error());
  return model_id;
}

Status copySubmapPair(const std::string& from, const std::string& folder, int index,
                      const Relocalizer& model, const ModelFileId& model_id,
                      std::vector<std::string>& warnings) {
  const std::string model_name = submapFileName(index);
  const std::string model_path = inSubmapFolder(folder, model_name);
  auto there = readRegularFile(model_path, modelFileFormat("submap model file"));
  if (there && modelFileId(*there) == model_id) return okStatus();
  std::vector<FileReplacement> pair;
  auto keyframes =
      readRegularFile(inSubmapFolder(from, keyFramesPath(model_name)), keyFrameFileFormat());
  if (keyframes)
    pair.push_back(keyFrameFileReplacement(inSubmapFolder(folder, keyFramesPath(model_name)),
                                           std::move(*keyframes)));
  else
    warnings.push_back(keyframes.error() + ": not copied to " + folder + " (submap " +
                       std::to_string(index) + " still answers from its model)");
  pair.push_back(modelFileReplacement(model_path, serializeModel(model.model())));
  return replaceFiles(pair);
}

SubmapManifest submapManifestHead(const std::string& place, const std::string& map_frame,
                                  const LearningParams& learning, const SubmapParams& submaps) {
  SubmapManifest manifest;
  manifest.place_name = place;
  manifest.map_frame = map_frame;
  manifest.software_version = kSoftwareVersion;
  manifest.min_motion = learning.min_motion;
  manifest.max_keyframes = learning.max_keyframes;
  manifest.submap_params = submaps;
  return manifest;
}

SubmapEntry frozenSubmapEntry(const std::string& place, int index,
                              const std::vector<SubmapKeyFrame>& key_frames,
                              const ModelFileId& model_id) {
  SubmapEntry entry;
  entry.index = index;
  entry.name = submapPlaceName(place, index);
  entry.model = submapFileName(index);
  entry.keyframes = keyFramesPath(entry.model);
  entry.keyframe_poses = key_frames;
  entry.model_id = model_id;
  return entry;
}

SubmapEntry activeSubmapFiles(const std::string& folder, const std::string& place, int index,
                              const std::vector<SubmapKeyFrame>& key_frames,
                              const OnlineLearner& active, std::vector<FileReplacement>& files) {
  SubmapEntry entry;
  entry.index = index;
  entry.name = submapPlaceName(place, index);
  entry.frozen = false;
  entry.keyframes = keyFramesPath(submapFileName(index));
  entry.keyframe_poses = key_frames;
  // The model first: the key frames then include every one it learned
  // (the active's store only grows).
  const std::shared_ptr<const Relocalizer> model = active.current();
  std::vector<uint8_t> model_bytes;
  if (model) {
    model_bytes = serializeModel(model->model());
    entry.model = submapFileName(index);
    entry.model_id = modelFileId(model_bytes);
  }
  files.push_back(keyFrameFileReplacement(inSubmapFolder(folder, entry.keyframes),
                                          serializeKeyFrames(active.keyFrames(), entry.model_id)));
  if (model)
    files.push_back(
        modelFileReplacement(inSubmapFolder(folder, entry.model), std::move(model_bytes)));
  return entry;
}

}  // namespace relocalizer
