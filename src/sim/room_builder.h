#pragma once
// Building the synthetic room from its seed: materials of several kinds, boxes
// placed in wall coordinates, the furniture and wall features made of them,
// and buildRoom's steps (synthetic_internal.h declares buildRoom). Private to
// the sim module.
//
// Every method draws from the one generator in a fixed order, so a seed always
// gives the same room: adding a draw anywhere changes every room after it.

#include <Eigen/Core>
#include <array>
#include <utility>
#include <vector>

#include "synthetic_internal.h"

namespace relocalizer {
namespace synthetic {

// Hue, saturation and value in [0, 1] (hue wraps) to linear RGB.
Vec3f hsv(float h, float s, float v);

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
// pieces elsewhere (RoomBuilder::rearrange). Recording draws nothing.
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
};

// Builds the room's contents in wall coordinates: s along the wall from its
// left corner (seen from inside), w out from the wall into the room, z up.
// Walls 0-3 run along y = 0, x = max, y = max and x = 0.
class RoomBuilder {
 public:
  RoomBuilder(SyntheticRoom::Impl& room, Rng& rng) : room_(room), rng_(rng) {}

  // ---- buildRoom's steps, in the order it takes them (room_layout.cpp)
  // Walls, floor and ceiling materials; returns the plain, texture-poor wall.
  int dressShell();
  // Corner pieces, skirting, a door, a window, furniture and decorations.
  void furnishWalls(int plain_wall);
  // A rug under the camera paths, turned a little.
  void layRug();
  // Two ceiling lights and their fittings.
  void hangLights();
  // Materials of the moving distractors and the phases of time-varying effects.
  void prepareEffects();
  // What furnishWalls placed.
  const FurnishingRecord& record() const { return record_; }

  // ---- a look-alike room (room_rearrangement.cpp): the same furniture and
  // decorations as `record`, moved to other places drawn from this builder's
  // generator, and new camera path phases. The boxes keep their sizes,
  // materials and texture coordinates (a piece moved to another wall turns
  // with it), so each piece looks exactly as before.
  void rearrange(const FurnishingRecord& record);

  // ---- materials (room_materials.cpp); each returns its index
  int material(Material m);
  int plain(const Vec3f& colour);
  int wood(int palette = -1);  // -1: a random wood
  int painted();
  Vec3f saturated();
  int spine();
  int posterMaterial(float width, float height, bool cork);
  int painting();
  int foliage();
  int speckle(const Vec3f& a, const Vec3f& b, const Vec3f& c);

  // ---- geometry
  struct Wall {
    Eigen::Vector2f corner, tangent, normal;
    float length;
  };
  Wall wall(int k) const;
  Vec3f wallPoint(int k, float s, float w, float z) const;
  // Face index of the face looking into the room from wall k.
  int frontFace(int k) const;
  int addBox(const Vec3f& lo, const Vec3f& hi, const std::array<int, 6>& faces);
  // An axis-aligned box given in wall coordinates; `front` (if >= 0) is the
  // material of the face looking into the room, `top` that of the upper face.
  int wallBox(int k, float s0, float s1, float w0, float w1, float z0, float z1, int m,
              int front = -1, int top = -1);
  // A box turned by `yaw` (radians) about its vertical axis, given by its
  // centre in wall coordinates and its half sizes along (s, w, z).
  void turnedBox(int k, float s, float w, float z, const Vec3f& half, float yaw,
                 const std::array<int, 6>& faces);

  // ---- furniture against wall k from s0 (room_furniture.cpp); each returns
  // the height of what it put against the wall, so decorations keep clear of it
  float bookshelf(int k, float s0, float width);
  float desk(int k, float s0, float width);
  float cabinet(int k, float s0, float width);
  float wardrobe(int k, float s0, float width);

  // ---- wall features and small pieces (room_wall_features.cpp)
  void door(int k, float s0, float width, float height);
  void window(int k, float s0, float width, float z0, float z1);
  void poster(int k, float sc, float zc, float w, float h);
  void framedPicture(int k, float sc, float zc, float w, float h);
  void corkboard(int k, float sc, float zc, float w, float h);
  void wallShelf(int k, float sc, float zc, float w);
  void plant(int k, float s, float w);
  void floorLamp(int k, float s, float w);

 private:
  struct WallPlan {
    int plain_wall, door_wall, window_wall;
    std::array<bool, 4> corner_used;
    int skirting;
  };

  // furnishWalls' steps for wall k.
  void furnishWall(int k, const WallPlan& plan);
  void placeDoor(int k, float start, float end, std::vector<Rect>& blocked,
                 std::vector<Interval>& no_furniture);
  void placeWindow(int k, float length, std::vector<Rect>& blocked,
                   std::vector<Interval>& no_furniture);
  void placeFurniture(int k, float start, float end, int max_items,
                      const std::vector<Interval>& no_furniture, std::vector<Rect>& blocked);
  void placeDecorations(int k, float length, float start, float end, int max_decor,
                        std::vector<Rect>& blocked);
  // A centre (s, z) drawn for a decoration w x h on a wall `length` long, and
  // whether one centred at (sc, zc) fits on a wall whose furniture spans
  // [start, end] beside what `blocked` holds.
  std::pair<float, float> drawDecorationSpot(float w, float h, float length);
  bool decorationFits(float sc, float zc, float w, float h, float start, float end,
                      const std::vector<Rect>& blocked) const;

  // rearrange's steps and its one motion: boxes [begin, end) from s = from_s
  // on wall `from` to s = to_s on wall `to`, raised by dz.
  void rearrangeFurniture(const FurnishingRecord& record,
                          std::array<std::vector<Rect>, 4>& blocked);
  // Where each piece of furniture may go, drawn afresh; wall -1 for a piece
  // that found no room. `depths`: how far each piece reaches into the room.
  struct Spot {
    int wall;
    float s;
  };
  std::vector<Spot> tryPlacingFurniture(const FurnishingRecord& record,
                                        const std::vector<float>& depths);
  void rearrangeDecorations(const FurnishingRecord& record,
                            std::array<std::vector<Rect>, 4>& blocked);
  // Phases of the camera paths' loops and wobbles.
  void drawPathPhases();
  void moveBoxes(int begin, int end, int from, float from_s, int to, float to_s, float dz);
  // How far a piece reaches out from its wall, where it stands now.
  float reach(const FurnishingRecord::Piece& piece) const;

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
  void curtains(int k, float s0, float s1, float frame, float z1);

  SyntheticRoom::Impl& room_;
  Rng& rng_;
  FurnishingRecord record_;
};

}  // namespace synthetic
}  // namespace relocalizer
