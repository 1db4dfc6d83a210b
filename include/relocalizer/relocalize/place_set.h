#pragma once
// Many places, one answer: a set of named models (rooms, floors, submaps), each
// with the frame its world coordinates are in (place.h), changed at run time
// while other threads relocalize against it through the place search
// (place_search.h), which says which place the frame is in.

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/relocalize/place.h"
#include "relocalizer/relocalize/place_search.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

// Names are one namespace. A group's name, and every name under it
// (`group/...`), is the group's: a place on its own may not take it, and a
// group may not be named after a place on its own nor take names under one's
// name. A place on its own replaces only a place on its own of its name.
// One model file twice in one map frame is refused (unless both are places
// of one group): the two would explain every frame alike, so every frame
// would be "ambiguous place" (issue 38, D1 and D3).
class PlaceSet {
 public:
  explicit PlaceSet(PlaceSearchParams params = {});

  // Loads a model file as a place, with its model_id. The error names the
  // place and the file.
  static Expected<Place> load(const std::string& name, const std::string& model_path,
                              const std::string& map_frame, const RelocalizerParams& params);

  // Adds a place, or replaces the one of the same name (a retrained model).
  // Refuses an empty name or frame, a model the parameters cannot use, a
  // group place in another frame than its group's, a name the namespace rules
  // above give to another, or a model file another place holds in that frame.
  Status put(Place place);
  // Makes `places` the group's places, all at once (a relocalization sees the
  // group before or after, never half): each gets `group`; the group's places
  // not among them go; one of the same name is replaced in its position.
  // Refuses (and changes nothing) an empty group, what put() refuses, two
  // places of one name or of two frames, a name held outside the group, a
  // group named after a place on its own (or over names under its name), or
  // a model file a place outside the group holds in that frame.
  Status putGroup(const std::string& group, std::vector<Place> places);
  // Removes the place of that name, or else every place of the group of that
  // name (a saved set of submaps goes as it came). False when neither is there.
  bool remove(const std::string& name);
  std::vector<PlaceFigures> list() const;
  std::vector<std::string> names() const;
  size_t size() const;
  // The places now, in the order they were added (shared: a later put or
  // remove does not change them).
  std::vector<std::shared_ptr<const Place>> places() const { return snapshot(); }

  // searchPlaces (place_search.h) over the places as they were when the call
  // started, searched again in the light of the best-screened place when no
  // place answered (light_retry.h): thread-safe, also against put/remove from
  // other threads.
  PlaceAnswer relocalize(const RgbdFrame& frame, const PoseHint* hint = nullptr) const;

  const PlaceSearchParams& params() const { return params_; }

 private:
  std::vector<std::shared_ptr<const Place>> snapshot() const;

  PlaceSearchParams params_;
  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<const Place>> places_;  // in the order they were added
};

}  // namespace relocalizer
