// The set's bookkeeping: the places, their names and model files, put and
// removed under one lock; a search runs over a snapshot (place_search.cpp).

#include "relocalizer/relocalize/place_set.h"

#include "relocalizer/core/file_io.h"
#include "relocalizer/relocalize/light_retry.h"

#include <algorithm>

namespace relocalizer {

namespace {

// Why a place cannot be put; empty when it can (the group's frame aside).
std::string placeError(const Place& place) {
  if (place.name.empty()) return "a place needs a name";
  if (place.map_frame.empty()) return "place " + place.name + ": no map frame";
  if (!place.relocalizer) return "place " + place.name + ": no model";
  if (std::string why = place.relocalizer->validationError(); !why.empty())
    return "place " + place.name + ": " + why;
  return {};
}

std::string groupFrameError(const Place& place, const std::string& frame) {
  return "place " + place.name + ": in " + place.map_frame + ", but group " + place.group +
         " is in " + frame + " (a group is one map)";
}

using PlaceList = std::vector<std::shared_ptr<const Place>>;

bool under(const std::string& name, const std::string& group) {
  return name.size() > group.size() && name.compare(0, group.size(), group) == 0 &&
         name[group.size()] == '/';
}

// Why a place on its own cannot take its name in `places` (namespace rules in
// place_set.h); empty when it can.
std::string soloNameError(const PlaceList& places, const std::string& name) {
  for (const auto& existing : places) {
    if (existing->group.empty()) continue;
    if (existing->group == name)
      return "'" + name + "' is the name of a group of places (a folder of submaps); unload it " +
             "first or choose another name";
    if (existing->name == name || under(name, existing->group))
      return "'" + name + "' is a name of group " + existing->group +
             "'s places; choose another name";
  }
  return {};
}

// Why `group` cannot be a group's name in `places`; empty when it can.
std::string groupNameError(const PlaceList& places, const std::string& group) {
  for (const auto& existing : places)
    if (existing->group.empty() && (existing->name == group || under(existing->name, group)))
      return existing->name == group
                 ? "'" + group + "' is a place on its own (a model file); unload it first or " +
                       "choose another name"
                 : "place '" + existing->name + "' (on its own) is under the name '" + group +
                       "'; unload it first or choose another name";
  return {};
}

// The place other than `place` (and outside its group) that holds its model
// file in its frame, or null.
const Place* sameModel(const PlaceList& places, const Place& place) {
  if (place.model_id.empty()) return nullptr;
  for (const auto& existing : places)
    if (existing->name != place.name && existing->model_id == place.model_id &&
        existing->map_frame == place.map_frame &&
        (place.group.empty() || existing->group != place.group))
      return existing.get();
  return nullptr;
}

std::string sameModelError(const Place& place, const Place& holder) {
  // A group goes as a whole (remove() by its name).
  const std::string owner = holder.group.empty() ? holder.name : holder.group;
  return "place " + place.name + ": its model (" + place.source + ") is already loaded as place " +
         holder.name + " (" + (holder.source.empty() ? "learned" : holder.source) + ")" +
         (holder.group.empty() ? "" : " of group " + holder.group) + " in " + place.map_frame +
         "; two places of one model in one frame would make every frame an ambiguous place: " +
         "unload " + owner + " first, or give another map_frame";
}

}  // namespace

PlaceSet::PlaceSet(PlaceSearchParams params) : params_(std::move(params)) {}

Expected<Place> PlaceSet::load(const std::string& name, const std::string& model_path,
                               const std::string& map_frame, const RelocalizerParams& params) {
  Expected<std::unique_ptr<Relocalizer>> relocalizer = makeError("not loaded");
  try {
    relocalizer = Relocalizer::fromFile(model_path, params);
  } catch (const std::exception& e) {
    // Whatever the loader throws (std::bad_alloc on a corrupt size) refuses
    // this place only.
    return makeError("place " + name + ": " + model_path +
                     ": cannot be loaded: " + loadFailureReason(e));
  }
  if (!relocalizer) return makeError("place " + name + ": " + relocalizer.error());
  Place place;
  place.name = name;
  place.map_frame = map_frame;
  place.source = model_path;
  place.relocalizer = std::move(*relocalizer);
  place.model_id = modelFileIdentity(model_path);
  return place;
}

Status PlaceSet::put(Place place) {
  if (std::string why = placeError(place); !why.empty()) return makeError(why);
  auto shared = std::make_shared<const Place>(std::move(place));
  std::lock_guard<std::mutex> lock(mutex_);
  if (shared->group.empty())
    if (std::string why = soloNameError(places_, shared->name); !why.empty())
      return makeError("place " + shared->name + ": " + why);
  if (const Place* holder = sameModel(places_, *shared))
    return makeError(sameModelError(*shared, *holder));
  if (!shared->group.empty())
    for (const auto& existing : places_)
      if (existing->group == shared->group && existing->name != shared->name &&
          existing->map_frame != shared->map_frame)
        return makeError(groupFrameError(*shared, existing->map_frame));
  for (auto& existing : places_)
    if (existing->name == shared->name) {
      existing = std::move(shared);
      return okStatus();
    }
  places_.push_back(std::move(shared));
  return okStatus();
}

Status PlaceSet::putGroup(const std::string& group, std::vector<Place> places) {
  if (group.empty()) return makeError("a group needs a name");
  std::vector<std::shared_ptr<const Place>> members;
  for (Place& place : places) {
    place.group = group;
    if (std::string why = placeError(place); !why.empty()) return makeError(why);
    for (const auto& member : members) {
      if (member->name == place.name)
        return makeError("place " + place.name + " is given twice in group " + group);
      if (member->map_frame != place.map_frame)
        return makeError(groupFrameError(place, member->map_frame));
    }
    members.push_back(std::make_shared<const Place>(std::move(place)));
  }
  auto memberNamed = [&](const std::string& name) {
    return std::find_if(members.begin(), members.end(),
                        [&](const auto& member) { return member->name == name; });
  };
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& existing : places_)
    if (existing->group != group && memberNamed(existing->name) != members.end())
      return makeError("place " + existing->name + " is not of group " + group);
  if (std::string why = groupNameError(places_, group); !why.empty()) return makeError(why);
  for (const auto& member : members)
    if (const Place* holder = sameModel(places_, *member))
      return makeError(sameModelError(*member, *holder));
  std::vector<std::shared_ptr<const Place>> updated;
  for (const auto& existing : places_) {
    if (existing->group != group) {
      updated.push_back(existing);
    } else if (auto member = memberNamed(existing->name); member != members.end()) {
      updated.push_back(std::move(*member));
      members.erase(member);
    }
  }
  for (auto& member : members) updated.push_back(std::move(member));
  places_ = std::move(updated);
  return okStatus();
}

bool PlaceSet::remove(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = std::find_if(places_.begin(), places_.end(),
                                  [&](const auto& place) { return place->name == name; });
  if (found != places_.end()) {
    places_.erase(found);
    return true;
  }
  const size_t before = places_.size();
  places_.erase(std::remove_if(places_.begin(), places_.end(),
                               [&](const auto& place) { return place->group == name; }),
                places_.end());
  return places_.size() != before;
}

std::vector<std::shared_ptr<const Place>> PlaceSet::snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return places_;
}

std::vector<PlaceFigures> PlaceSet::list() const {
  std::vector<PlaceFigures> figures;
  for (const auto& place : snapshot()) figures.push_back(placeFigures(*place));
  return figures;
}

std::vector<std::string> PlaceSet::names() const {
  std::vector<std::string> names;
  for (const auto& place : snapshot()) names.push_back(place->name);
  return names;
}

PlaceAnswer PlaceSet::relocalize(const RgbdFrame& frame, const PoseHint* hint) const {
  const std::vector<std::shared_ptr<const Place>> places = snapshot();
  return searchedAgainInTrainingLight(places, frame, hint, params_,
                                      searchPlaces(places, frame, hint, params_));
}

size_t PlaceSet::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return places_.size();
}

}  // namespace relocalizer
