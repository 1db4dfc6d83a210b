#pragma once
// evaluate's sets of learned submaps as places: the set a run learns
// (--submaps) and a saved folder (--model FOLDER) are relocalized across alike,
// as one group of places in one map frame (relocalize/place_set.h).

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/eval/frame_evaluation.h"
#include "relocalizer/online/submap_folder.h"
#include "relocalizer/online/submap_learner.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer::cli {

// Every submap with a model as a place of one group, in one map frame.
inline Status putSubmaps(const SubmapLearner& submaps, PlaceSet& places) {
  const SubmapNames& names = submaps.names();
  std::vector<Place> group;
  for (const SubmapModel& m : submaps.models())
    group.push_back({submapPlaceName(names.place, m.index), names.map_frame, "submap",
                     m.relocalizer, names.place});
  return places.putGroup(names.place, std::move(group));
}

// A --model folder is a set of learned submaps (its manifest.json says what is in it).
inline bool isFolder(const std::string& path) {
  std::error_code ec;
  return !path.empty() && std::filesystem::is_directory(path, ec);
}

// --model FOLDER: a saved set of learned submaps, relocalized across as --submaps
// does (a submap that cannot be loaded is skipped with a warning).
inline Expected<FrameEvaluation> evaluateSubmapFolder(const std::string& folder,
                                                      const RelocalizerParams& params,
                                                      const FrameSource& data) {
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
  auto resumed = submaps.resume(folder);
  if (!resumed) return makeError(resumed.error());
  for (const std::string& warning : *resumed) std::printf("warning: %s\n", warning.c_str());
  PlaceSet places;
  if (Status put = putSubmaps(submaps, places); !put) return makeError(put.error());
  if (places.size() == 0) return makeError(folder + ": no submap could be loaded");
  std::printf("%s: %zu submaps of %s in %s\n", folder.c_str(), places.size(),
              manifest->place_name.c_str(), manifest->map_frame.c_str());
  return evaluateFrames(places, data, "evaluating " + std::to_string(places.size()) + " submaps");
}

}  // namespace relocalizer::cli
