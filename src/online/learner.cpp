#include "relocalizer/online/learner.h"

namespace relocalizer {

Status putLearned(std::vector<Place> learned, PlaceSet& places) {
  if (learned.empty()) return okStatus();
  const std::string group = learned.front().group;
  return places.putGroup(group, std::move(learned));
}

}  // namespace relocalizer
