#pragma once
// The places the node loads at start (node_places.h): `model`'s place and
// the `places` list, as given and checked entry by entry.

#include <string>
#include <vector>

#include "param_reading.h"

namespace relocalizer_ros {

// One entry of the `places` parameter.
struct PlaceSpec {
  std::string name;
  std::string model;
  std::string map_frame;  // the node's map_frame when the entry names none
  // Why this place cannot be loaded, naming the parameter (a name or frame
  // the name rule refuses, core/outside_text.h); empty when it can. A place
  // refused is one place that does not load, not a node that cannot start.
  std::string refused;
};

struct PlaceSettings {
  std::string model;
  // The name of `model`'s place (learn: of the learned place); empty: the
  // model file's stem, or "learned" (placeName()).
  std::string place_name;
  std::vector<PlaceSpec> places;    // further places, as given
  std::string model_place_refused;  // as PlaceSpec::refused, for `model`'s place
};

// model, place_name and `places`, a list of {name, model, map_frame} whose
// entries without a map_frame are in `map_frame`. A typo in a key or a name
// used twice is refused, never a place silently missing or shadowed.
void readPlaceSettings(ParamReader& reader, const std::string& map_frame, PlaceSettings& places);

// The name of `model`'s place, or of the learned place when `learn`.
std::string placeName(const PlaceSettings& places, bool learn);
// `name` is the learned place `learned` or one of its submaps' (`learned`/i),
// names the learner owns; `learned` is "" outside learn mode.
bool isLearnedPlaceName(const std::string& learned, const std::string& name);
// The places to load at start: `places`, then `model`'s place in `map_frame`
// (not in learn mode, where `model` is the learned place's start).
std::vector<PlaceSpec> startupPlaces(const PlaceSettings& places, bool learn,
                                     const std::string& map_frame);

}  // namespace relocalizer_ros
