#pragma once
// The primitives every piece of the synthetic room is built from: materials of
// several kinds and boxes placed in wall coordinates. The pieces made of them
// are in room_furniture.h and room_wall_features.h, where they go in
// room_layout.h (buildRoom's steps) and room_rearrangement.h. Private to the
// sim module.
//
// Every piece draws from the one generator in a fixed order, so a seed always
// gives the same room: adding a draw anywhere changes every room after it.

#include <Eigen/Core>
#include <array>

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

  // The room being built, and the generator every piece draws from.
  SyntheticRoom::Impl& room() { return room_; }
  Rng& rng() { return rng_; }

  // ---- materials; each returns its index
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

 private:
  SyntheticRoom::Impl& room_;
  Rng& rng_;
};

}  // namespace synthetic
}  // namespace relocalizer
