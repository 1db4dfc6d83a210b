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
#include <vector>

#include "synthetic_internal.h"

namespace relocalizer {
namespace synthetic {

// Hue, saturation and value in [0, 1] (hue wraps) to linear RGB.
Vec3f hsv(float h, float s, float v);

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
  // Where a wall must stay clear: s ranges without furniture, and rectangles
  // (s, z) that decorations must not overlap.
  struct Interval {
    float lo, hi;
    bool overlaps(float a, float b) const { return a < hi && b > lo; }
  };
  struct Rect {
    float s0, s1, z0, z1;
  };
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
};

}  // namespace synthetic
}  // namespace relocalizer
