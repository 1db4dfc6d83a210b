#pragma once
// Features of a wall (a door, a window with curtains and a radiator,
// decorations) and small free-standing pieces (plants, a floor lamp). Private
// to the sim module.

#include "room_builder.h"

namespace relocalizer {
namespace synthetic {

// Wall features on wall k, built with `builder`'s materials and boxes and drawn
// from its generator: s0 where a door or window starts, (sc, zc) the centre
// of a decoration w x h, (s, w) where a free-standing piece stands.
class WallFeatures {
 public:
  explicit WallFeatures(RoomBuilder& builder) : b_(builder), rng_(builder.rng()) {}

  void door(int k, float s0, float width, float height);
  void window(int k, float s0, float width, float z0, float z1);
  void poster(int k, float sc, float zc, float w, float h);
  void framedPicture(int k, float sc, float zc, float w, float h);
  void corkboard(int k, float sc, float zc, float w, float h);
  void wallShelf(int k, float sc, float zc, float w);
  void plant(int k, float s, float w);
  void floorLamp(int k, float s, float w);

 private:
  void curtains(int k, float s0, float s1, float frame, float z1);

  RoomBuilder& b_;
  Rng& rng_;
};

}  // namespace synthetic
}  // namespace relocalizer
