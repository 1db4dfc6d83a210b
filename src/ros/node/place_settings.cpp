#include "place_settings.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <utility>

#include "../conversion/message_conversion.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/core/outside_text.h"

namespace relocalizer_ros {

namespace {

constexpr const char* kPlaceForm = "{name: NAME, model: FILE, map_frame: FRAME (optional)}";

// One field of a `places` entry: absent is "", anything but a string an error.
std::string placeField(XmlRpc::XmlRpcValue& entry, const char* key, const std::string& entry_name,
                       std::string& value) {
  if (!entry.hasMember(key)) return {};
  if (entry[key].getType() != XmlRpc::XmlRpcValue::TypeString)
    return "'" + entry_name + "/" + key + "' must be a string";
  value = static_cast<std::string>(entry[key]);
  return {};
}

std::string placeEntry(XmlRpc::XmlRpcValue& entry, const std::string& entry_name,
                       const std::string& map_frame, PlaceSpec& place) {
  if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct)
    return "'" + entry_name + "' must be " + kPlaceForm;
  for (const auto& member : entry)
    if (member.first != "name" && member.first != "model" && member.first != "map_frame")
      return "'" + entry_name + "' has an unknown key '" + member.first + "'; expected " +
             kPlaceForm;
  for (auto [key, field] :
       {std::pair{"name", &place.name}, {"model", &place.model}, {"map_frame", &place.map_frame}})
    if (std::string why = placeField(entry, key, entry_name, *field); !why.empty()) return why;
  if (place.name.empty()) return "'" + entry_name + "' has no name; expected " + kPlaceForm;
  if (place.model.empty()) return "'" + entry_name + "' has no model; expected " + kPlaceForm;
  place.map_frame = stripLeadingSlashes(place.map_frame);
  if (place.map_frame.empty()) place.map_frame = map_frame;
  for (auto [key, field] : {std::pair{"name", &place.name}, {"map_frame", &place.map_frame}})
    if (place.refused.empty())
      place.refused = relocalizer::nameError(*field, "'" + entry_name + "/" + key + "'");
  return {};
}

std::string readPlaces(const ros::NodeHandle& nh, const std::string& map_frame,
                       std::vector<PlaceSpec>& places) {
  if (!nh.hasParam("places")) return {};
  const std::string name = nh.resolveName("places");
  XmlRpc::XmlRpcValue list;
  nh.getParam("places", list);
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray)
    return "parameter '" + name + "' must be a list of " + kPlaceForm;
  for (int i = 0; i < list.size(); ++i) {
    const std::string entry_name = name + "[" + std::to_string(i) + "]";
    PlaceSpec place;
    if (std::string why = placeEntry(list[i], entry_name, map_frame, place); !why.empty())
      return why;
    for (size_t j = 0; j < places.size(); ++j)
      if (places[j].name == place.name)
        return "'" + entry_name + "' is named '" + place.name + "' like places[" +
               std::to_string(j) + "]; place names must be unique";
    places.push_back(std::move(place));
  }
  return {};
}

}  // namespace

void readPlaceSettings(ParamReader& reader, const std::string& map_frame, PlaceSettings& places) {
  reader.read("model", places.model);
  reader.read("place_name", places.place_name);
  if (reader.ok()) reader.fail(readPlaces(reader.handle(), map_frame, places.places));
}

std::string placeName(const PlaceSettings& places, bool learn) {
  if (!places.place_name.empty()) return places.place_name;
  if (learn) return "learned";
  return relocalizer::pathStem(places.model);
}

bool isLearnedPlaceName(const std::string& learned, const std::string& name) {
  if (learned.empty()) return false;
  return name == learned || name.rfind(learned + "/", 0) == 0;
}

std::vector<PlaceSpec> startupPlaces(const PlaceSettings& places, bool learn,
                                     const std::string& map_frame) {
  std::vector<PlaceSpec> startup = places.places;
  if (!learn && !places.model.empty())
    startup.push_back(
        {placeName(places, learn), places.model, map_frame, places.model_place_refused});
  return startup;
}

}  // namespace relocalizer_ros
