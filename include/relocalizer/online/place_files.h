#pragma once
// A place on disk, as a path names it (the node's `model` and `places`
// parameters and ~load_place, evaluate --model, places_benchmark --place and
// --submaps): a model file is one place; a folder of learned submaps
// (submap_folder.h) is a group of places `<name>/<index>`. ROS-free, so that
// the node's load requests are fuzzed as the node runs them
// (test/fuzz/fuzz_place_requests.cpp).
//
// Loads are bounded: at most kConcurrentPlaceLoads run at once in a process
// (each holds its file's bytes and inflates its trees on every core); the
// others wait their turn. 64 service calls loading at once would otherwise
// hold 64 files in memory together.

#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer {

constexpr int kConcurrentPlaceLoads = 2;

struct PlaceFiles {
  std::vector<Place> places;
  bool folder = false;          // a saved set of submaps, not one model file
  std::string name;             // the place's (a folder's: its group's), as asked for or as saved
  std::string map_frame;        // the frame its places answer in, as asked for or as saved
  std::string saved_map_frame;  // a folder's: the frame it was learned in
  std::vector<std::string> warnings;  // a folder's submaps skipped, each naming its file
};

// Whether `path` names a folder (of learned submaps, or nothing of ours),
// not a model file: how openPlace decides, for callers that check options
// before opening.
bool placeIsFolder(const std::string& path);

// The one opener of a place on disk, for the node, the tools and the
// benchmarks alike: the model file or the folder of learned submaps at
// `path`, as places named `name` in `map_frame`. Empty `name` or `map_frame`:
// as the folder was saved (a model file: its stem, in "map"). Never throws:
// a path that does not load is an error naming the place, the path and what
// was expected there.
Expected<PlaceFiles> openPlace(const std::string& name, const std::string& path,
                               const std::string& map_frame, const RelocalizerParams& params);

// Puts them into `set`: the model file's place, or the folder's as group `name`.
Status putPlaceFiles(PlaceSet& set, const std::string& name, PlaceFiles files);

// For a path a peer names: one answer, "cannot load place '<name>': ...",
// whether the path is missing, unreadable, neither a model file nor a folder
// with a manifest, or not text (invalid UTF-8, control characters), so that
// the answer tells nothing of files the caller could not read; empty when
// the path opens as a model file (its magic) or a folder whose manifest
// opens, when the loader's own error applies.
std::string unreadablePlaceError(const std::string& name, const std::string& path);

}  // namespace relocalizer
