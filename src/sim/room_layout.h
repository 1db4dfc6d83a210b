#pragma once
// Where the room's pieces go on its walls: the stretches kept clear, the
// record of what went where, and the rules that buildRoom's layout
// (room_layout.cpp) and a look-alike's rearrangement (room_rearrangement.cpp)
// share. Private to the sim module.

#include <array>
#include <optional>
#include <utility>
#include <vector>

#include "room_wall_features.h"

namespace relocalizer {
namespace synthetic {

// Where a wall must stay clear: s ranges without furniture, and rectangles
// (s, z) that decorations must not overlap.
struct Interval {
  float lo, hi;
  bool overlaps(float a, float b) const { return a < hi && b > lo; }
};
struct Rect {
  float s0, s1, z0, z1;
};

// What a piece of furniture from s0 to s1, `top` high, keeps decorations off.
inline Rect furnitureClearance(float s0, float s1, float top) {
  return {s0 - 0.05f, s1 + 0.05f, 0, top + 0.12f};
}

// What furnishWalls put where, so that a look-alike room can place the same
// pieces elsewhere (room_rearrangement.h). Recording draws nothing.
struct FurnishingRecord {
  struct Wall {
    float length = 0, start = 0, end = 0;  // furniture stays within [start, end]
    std::vector<Interval> no_furniture;    // the door and window stretches
    std::vector<Rect> fixed;               // the door and window, kept clear of decorations
  };
  // One piece of furniture or one decoration: its boxes [box_begin, box_end)
  // and the (s, z) extent it takes on its wall (z0 = 0 for furniture, z1 its top).
  struct Piece {
    int wall;
    float s0, s1, z0, z1;
    int box_begin, box_end;
  };
  std::array<Wall, 4> walls;
  std::vector<Piece> furniture, decorations;
  // Small things on the furniture (Furniture::smallObjects): only their boxes
  // are known, and they move with their piece.
  std::vector<std::pair<int, int>> objects;
};

// A centre (s, z) drawn for a decoration w x h on a wall `length` long in a room
// `room_height` high, and whether one centred at (sc, zc) fits on a wall whose
// furniture spans [start, end] beside what `blocked` holds.
std::pair<float, float> drawDecorationSpot(Rng& rng, float room_height, float w, float h,
                                           float length);
bool decorationFits(float room_height, float sc, float zc, float w, float h, float start, float end,
                    const std::vector<Rect>& blocked);

// One try at a decoration on wall k, drawn from `b`'s generator as the room's
// own are (a poster, a picture, a cork board or a shelf with things on it, at
// a spot drawn along the wall): hung when the spot is clear of `blocked`
// (which then holds it too), nothing otherwise.
std::optional<FurnishingRecord::Piece> tryDecoration(RoomBuilder& b, WallFeatures& features, int k,
                                                     const FurnishingRecord::Wall& wall,
                                                     std::vector<Rect>& blocked);

// Phases of the camera paths' loops and wobbles.
void drawPathPhases(SyntheticRoom::Impl& room, Rng& rng);

}  // namespace synthetic
}  // namespace relocalizer
