#pragma once
// The tools' sets of learned submaps as places (evaluate, learn_benchmark): the set a run learns
// (--submaps) and a saved folder (--model FOLDER) are relocalized across alike,
// as one group of places in one map frame (relocalize/place_set.h).

#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/eval/frame_evaluation.h"
#include "relocalizer/online/submap_folder.h"
#include "relocalizer/online/submap_learner.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer::cli {

// `models` (the learner's models(), read once by the caller) as the places
// of the learner's group, in its map frame.
inline Status putSubmaps(const SubmapLearner& submaps, const std::vector<SubmapModel>& models,
                         PlaceSet& places) {
  const SubmapNames& names = submaps.names();
  return places.putGroup(names.place, submapPlaces(models, names.place, names.map_frame));
}

// A --model folder is a set of learned submaps (its manifest.json says what is in it).
inline bool isFolder(const std::string& path) {
  std::error_code ec;
  return !path.empty() && std::filesystem::is_directory(path, ec);
}

// --model FOLDER: a saved set of learned submaps, relocalized across as --submaps
// does (a submap that cannot be loaded is skipped with a warning); `hints_in`
// makes the hints (or none) for the set's map frame.
inline Expected<FrameEvaluation> evaluateSubmapFolder(
    const std::string& folder, const RelocalizerParams& params, const FrameSource& data,
    const std::function<std::unique_ptr<SimulatedHints>(const std::string&)>& hints_in) {
  auto manifest = readSubmapManifest(folder);
  if (!manifest) return makeError(manifest.error());
  auto saved = loadSavedSubmaps(folder, manifest->place_name, manifest->map_frame, params);
  if (!saved) return makeError(saved.error());
  for (const std::string& warning : saved->warnings) std::printf("warning: %s\n", warning.c_str());
  PlaceSet places;
  if (Status put = places.putGroup(manifest->place_name, std::move(saved->places)); !put)
    return makeError(put.error());
  std::printf("%s: %zu submaps of %s in %s\n", folder.c_str(), places.size(),
              manifest->place_name.c_str(), manifest->map_frame.c_str());
  return evaluateFrames(places, data, "evaluating " + std::to_string(places.size()) + " submaps",
                        hints_in(manifest->map_frame).get());
}

}  // namespace relocalizer::cli
