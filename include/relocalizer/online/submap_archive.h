#pragma once
// A set of learned submaps on disk (the folder and manifest of
// submap_folder.h), read and written file by file: what a learner continuing
// the set (submap_learner.h) and a reader answering from it share. The reader,
// loadSavedSubmaps, builds no learner: it loads every submap's model, the
// active one's only beside the key frames it was saved with, as a learner
// continuing it would.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/online/keyframe_store.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/online/submap_folder.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer {

// `<folder>/<name>`.
std::string inSubmapFolder(const std::string& folder, const std::string& name);

// --- Reading ----------------------------------------------------------------

// The active submap of a saved set (`entry`) as a learner continues it: from
// its model and key frames (OnlineLearner::resume), or from its key frames
// alone when it was saved before its first model.
Expected<std::shared_ptr<OnlineLearner>> continueActiveSubmap(const std::string& folder,
                                                              const SubmapEntry& entry,
                                                              const LearningParams& learning,
                                                              const RelocalizerParams& params,
                                                              OnlineLearner::Mode mode);

// Reads the active submap: a note to warn of (empty: none), or why it is skipped.
using ActiveSubmapReader = std::function<Expected<std::string>(const SubmapEntry& entry)>;

// The frozen submaps of a saved set as read from `folder`, by index.
struct ReadSubmaps {
  std::vector<std::shared_ptr<const Relocalizer>> frozen;  // null: skipped, or not frozen
  std::vector<std::string> warnings;  // the submaps skipped, naming each file and why
};
// Reads the submaps `manifest` names, in its order: a frozen one's model is
// loaded, served with `served` (`surveyed` for one without key-frame poses: a
// model made by `train`, SubmapIndex::surveyedSubmaps), and must be the file
// the manifest names; the
// active one goes to `active` (or is read as frozen when it holds more key
// frames than `max_keyframes`, which a store could not hold in order). A
// submap named through a symbolic link, or that does not load, is skipped
// with a warning; so are files the manifest does not name.
ReadSubmaps readSubmaps(const std::string& folder, const SubmapManifest& manifest,
                        int max_keyframes, const RelocalizerParams& served,
                        const RelocalizerParams& surveyed, const ActiveSubmapReader& active);

// A model made by `train` (no key frames beside it) served with `params`, as a
// surveyed submap; errors name `path` and say why.
Expected<std::shared_ptr<const Relocalizer>> loadSurveyedModel(const std::string& path,
                                                               const RelocalizerParams& params);

// A saved set loaded to answer, not to learn more: every submap with a model
// that loads, as places `<group>/<index>` of `group` in `map_frame` (empty:
// the place name and map frame the set was saved with), served as the
// learner served them (learnedModelParams; a survey made by `train` as it was
// made: with the parameters given), each with its file as source and
// identity (a folder loaded twice, by a copy or another spelling, is refused
// as one model file twice is: PlaceSet).
struct SavedSubmaps {
  std::vector<Place> places;
  std::string saved_place_name;       // the place name the set was learned as (manifest)
  std::string saved_map_frame;        // the frame the set was learned in (manifest)
  std::vector<std::string> warnings;  // the submaps skipped, naming each file and why
};
// Fails, naming the file, when the manifest is missing or unreadable, or when
// no submap could be loaded. Never throws.
Expected<SavedSubmaps> loadSavedSubmaps(const std::string& folder, std::string group,
                                        std::string map_frame, const RelocalizerParams& params);

// --- Writing ----------------------------------------------------------------

// `folder` made ready to hold a set: created if need be, refused when it is
// something else (a file, a pipe: never replaced) or holds someone else's
// manifest.json (not ours to fill; checked before any submap file is written).
Status prepareSubmapFolder(const std::string& folder);

// Submap `index`'s key frames and model into `folder`, key frames first (as
// OnlineLearner::save: their model identity then tells a pair cut by a
// crash). Returns the model file's identity.
Expected<ModelFileId> writeSubmapPair(const std::string& folder, int index,
                                      const Relocalizer& model,
                                      const std::vector<KeyFrameStore::Entry>& key_frames);

// A frozen submap's pair into `folder` from the working folder `from` (its
// key frames; the model from memory), unless `folder` holds its model
// already: frozen files never change. Key frames that cannot be read are a
// warning (the submap still answers from its model).
Status copySubmapPair(const std::string& from, const std::string& folder, int index,
                      const Relocalizer& model, const ModelFileId& model_id,
                      std::vector<std::string>& warnings);

// The manifest's head: the names and settings a set is learned with.
SubmapManifest submapManifestHead(const std::string& place, const std::string& map_frame,
                                  const LearningParams& learning, const SubmapParams& submaps);
// A frozen submap's manifest entry.
SubmapEntry frozenSubmapEntry(const std::string& place, int index,
                              const std::vector<SubmapKeyFrame>& key_frames,
                              const ModelFileId& model_id);
// The active submap `index` (learner `active`, key frames `key_frames` in the
// index) as an entry of the manifest and its files in `folder`, appended to
// `files`: the model it has now (none before its first retrain) and its key
// frames.
SubmapEntry activeSubmapFiles(const std::string& folder, const std::string& place, int index,
                              const std::vector<SubmapKeyFrame>& key_frames,
                              const OnlineLearner& active, std::vector<FileReplacement>& files);

}  // namespace relocalizer
