#pragma once
// Furniture against a wall: bookshelves, desks, cabinets, wardrobes, and the
// things on them. Private to the sim module.

#include <utility>
#include <vector>

#include "room_builder.h"

namespace relocalizer {
namespace synthetic {

// Pieces of furniture against wall k from s0, built with `builder`'s materials
// and boxes and drawn from its generator. Each returns the height of what it
// put against the wall, so decorations keep clear of it.
class Furniture {
 public:
  explicit Furniture(RoomBuilder& builder) : b_(builder), rng_(builder.rng()) {}

  float bookshelf(int k, float s0, float width);
  float desk(int k, float s0, float width);
  float cabinet(int k, float s0, float width);
  float wardrobe(int k, float s0, float width);

  // The boxes [begin, end) of each small thing put on the furniture so far
  // (book stacks, mugs, vases, plants, photos on desks and cabinets), so that
  // a changed room can take some away.
  const std::vector<std::pair<int, int>>& smallObjects() const { return objects_; }

 private:
  // Records the boxes added since `begin` as one small object.
  void recordObject(int begin);
  // Pieces of the furniture above.
  void shelfOfBooks(int k, float s0, float s1, float depth, float z0, float pitch, int pages);
  void bookStack(int k, float s, float w, float z, int count);
  void deskDrawers(int k, float s0, float s1, float depth, float height);
  // A monitor on the desk, maybe; returns where the free desk top begins.
  float deskMonitor(int k, float s0, float width, float height, float& top_height);
  void deskClutter(int k, float s1, float depth, float height, float free_s);
  void pushedInChair(int k, float s0, float width, float depth);
  void cabinetFronts(int k, float s0, float width, float depth, float height, int fronts,
                     int handle);
  float television(int k, float s0, float width, float height);
  float cabinetTopObjects(int k, float s0, float s1, float depth, float height);

  RoomBuilder& b_;
  Rng& rng_;
  std::vector<std::pair<int, int>> objects_;
};

}  // namespace synthetic
}  // namespace relocalizer
