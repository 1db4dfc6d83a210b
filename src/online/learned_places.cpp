#include "relocalizer/online/learned_places.h"

#include "relocalizer/online/submap_folder.h"

namespace relocalizer {

std::vector<Place> learnedPlaces(const std::vector<SubmapModel>& models, const SubmapNames& names,
                                 LoneSubmap lone) {
  std::vector<Place> places;
  for (const SubmapModel& m : models)
    places.push_back(
        {submapPlaceName(names.place, m.index), names.map_frame, "", m.relocalizer, names.place,
         m.file.size ? modelIdentity(m.file.crc, m.file.size) : std::string(), m.part});
  if (lone == LoneSubmap::AsThePlace && models.size() == 1 && models[0].index == 0)
    places[0].name = names.place;
  return places;
}

Status putLearnedPlaces(PlaceSet& places, const std::vector<SubmapModel>& models,
                        const SubmapNames& names, LoneSubmap lone) {
  return places.putGroup(names.place, learnedPlaces(models, names, lone));
}

}  // namespace relocalizer
