#pragma once
// evaluate --model NAME=PATH (repeated): the places a user names, each opened
// as the node opens one (online/place_files.h: a model file, or a folder of
// learned submaps as one group), relocalized across as one set.

#include <cstdio>
#include <string>

#include "evaluate_options.h"
#include "place_arguments.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/eval/frame_evaluation.h"
#include "relocalizer/online/place_files.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer::cli {

// Every --model NAME=PATH in one set, each place in map frame NAME; every
// frame is relocalized against the whole set.
inline Expected<FrameEvaluation> evaluateNamedPlaces(const Options& o,
                                                     const RelocalizerParams& params,
                                                     const FrameSource& data) {
  auto arguments = parseNamedPaths(o.models, "--model");
  if (!arguments) return makeError(arguments.error());
  PlaceSet places;
  bool expected_found = o.expect_place.empty();
  for (const auto& [name, path] : *arguments) {
    auto opened = openPlace(name, path, name, params);
    if (!opened) return makeError(opened.error());
    for (const std::string& warning : opened->warnings)
      std::printf("warning: %s\n", warning.c_str());
    // Answers name a folder's places NAME/INDEX, never the group itself.
    if (opened->folder && name == o.expect_place)
      return makeError("--expect-place " + name + ": " + path +
                       " is a folder of submaps, whose places are " + name +
                       "/<index>: expect one of those");
    for (const Place& place : opened->places) {
      expected_found = expected_found || place.name == o.expect_place;
      const PlaceFigures figures = placeFigures(place);
      std::printf("place %s: %s, %d point trees, %d line trees, %.1f MB in memory\n",
                  place.name.c_str(), place.source.c_str(), figures.point_trees, figures.line_trees,
                  figures.model_bytes / 1e6);
    }
    if (Status added = putPlaceFiles(places, name, std::move(*opened)); !added)
      return makeError(added.error());
  }
  if (!expected_found)
    return makeError("--expect-place " + o.expect_place + ": no --model names that place");
  return evaluateFrames(places, data, "evaluating " + std::to_string(places.size()) + " places",
                        o.hints(o.expect_place).get());
}

}  // namespace relocalizer::cli
