#pragma once
// A place: a named model with the frame its world coordinates are in, what a
// PlaceSet holds and a place search (place_search.h) answers among; the
// identity of its model file, and what a listing shows of it.

#include <cstdint>
#include <memory>
#include <string>

#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

struct Place {
  std::string name;       // unique within a set; what answers and logs say
  std::string map_frame;  // the frame the model's world coordinates are in
  std::string source;     // where the model came from (its path), for listings
  std::shared_ptr<const Relocalizer> relocalizer;
  // Places of one group are parts of one map (submaps): one map frame, and
  // answers that agree are one answer, not rivals. Empty: a place on its own.
  // A shared map_frame alone does not make one map: two models a user loads
  // into one frame stay rivals, as they were before groups.
  std::string group;
  // The model file's identity (modelFileIdentity), as PlaceSet::load or a
  // folder's loader (place_files.h) read it; empty for a model that is no
  // file's (built in memory, learned).
  std::string model_id;
  // Places of one group learned in different stretches of SLAM's map (the
  // submaps before and after SLAM's map moved under them, a reset: the
  // learner's new place) are different parts. Where both know the room their
  // answers in the one frame are metres apart, so one part never answers
  // alone where a newer could: when a place answers, the best screened place
  // of every newer part of its group is solved too, and an older part's
  // answer is given only when no newer part's disagrees, however few the
  // newer one's inliers (place_search.h). The higher part is the newer.
  int part = 0;
};

// A model file's identity for Place::model_id, from its contents (CRC-32 and
// size), so that a copy, a link or another spelling of the path is the same
// model; empty when it cannot be read (then nothing is compared).
std::string modelFileIdentity(const std::string& path);
// The same from a file's CRC-32 and size known already (a learned submap's
// file as it was written).
std::string modelIdentity(uint32_t crc32, uint64_t bytes);

// What a listing shows of a place.
struct PlaceFigures {
  std::string name;
  std::string map_frame;
  std::string source;
  std::string group;
  int point_trees = 0;
  int line_trees = 0;
  long modes = 0;            // leaf modes over both forests
  long surface_voxels = 0;   // the scene surface's voxels (0: none)
  long training_frames = 0;  // frames the model was trained on
  uint64_t model_bytes = 0;  // forests and surface in memory
};

PlaceFigures placeFigures(const Place& place);

}  // namespace relocalizer
