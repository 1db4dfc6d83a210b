#pragma once
// The tools' sets of learned submaps as places (evaluate, learn_benchmark): the set a run learns
// (--submaps) and a saved folder (--model FOLDER) are relocalized across alike,
// as one group of places in one map frame (relocalize/place_set.h).

#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/eval/frame_evaluation.h"
#include "relocalizer/online/place_files.h"
#include "relocalizer/online/submap_learner.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer::cli {

// --model FOLDER: a saved set of learned submaps, opened as the node opens
// one (online/place_files.h) under the name and map frame it was saved with,
// and relocalized across as --submaps does (a submap that cannot be loaded is
// skipped with a warning); `hints_in` makes the hints (or none) for the set's
// map frame.
inline Expected<FrameEvaluation> evaluateSubmapFolder(
    const std::string& folder, const RelocalizerParams& params, const FrameSource& data,
    const std::function<std::unique_ptr<SimulatedHints>(const std::string&)>& hints_in) {
  auto opened = openPlace("", folder, "", params);
  if (!opened) return makeError(opened.error());
  for (const std::string& warning : opened->warnings) std::printf("warning: %s\n", warning.c_str());
  const std::string name = opened->name, map_frame = opened->map_frame;
  PlaceSet places;
  if (Status put = putPlaceFiles(places, name, std::move(*opened)); !put)
    return makeError(put.error());
  std::printf("%s: %zu submaps of %s in %s\n", folder.c_str(), places.size(), name.c_str(),
              map_frame.c_str());
  return evaluateFrames(places, data, "evaluating " + std::to_string(places.size()) + " submaps",
                        hints_in(map_frame).get());
}

}  // namespace relocalizer::cli
