// The room builder's primitives: materials of each kind, and boxes placed in
// wall coordinates.

#include "room_builder.h"

#include <cmath>

namespace relocalizer {
namespace synthetic {

Vec3f hsv(float h, float s, float v) {
  h = fract(h) * 6.0f;
  const int i = static_cast<int>(h);
  const float f = h - i, p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  switch (i) {
    case 0:
      return {v, t, p};
    case 1:
      return {q, v, p};
    case 2:
      return {p, v, t};
    case 3:
      return {p, q, v};
    case 4:
      return {t, p, v};
    default:
      return {v, p, q};
  }
}

// ---------------------------------------------------------------- materials

int RoomBuilder::material(Material m) {
  m.seed = rng_.seed32();
  room_.materials.push_back(m);
  return static_cast<int>(room_.materials.size()) - 1;
}

int RoomBuilder::plain(const Vec3f& colour) {
  Material m;
  m.pattern = Pattern::kPlain;
  m.a = colour;
  return material(m);
}

int RoomBuilder::wood(int palette) {
  static const std::array<std::array<float, 6>, 5> kWoods = {{
      {0.78f, 0.62f, 0.42f, 0.62f, 0.45f, 0.28f},  // oak
      {0.45f, 0.30f, 0.20f, 0.30f, 0.18f, 0.11f},  // walnut
      {0.70f, 0.42f, 0.30f, 0.52f, 0.28f, 0.18f},  // cherry
      {0.88f, 0.78f, 0.62f, 0.76f, 0.64f, 0.48f},  // birch
      {0.30f, 0.22f, 0.17f, 0.18f, 0.12f, 0.09f},  // dark stain
  }};
  const auto& w = kWoods[palette >= 0 ? palette : rng_.integer(0, 4)];
  Material m;
  m.pattern = Pattern::kWood;
  m.a = Vec3f(w[0], w[1], w[2]);
  m.b = Vec3f(w[3], w[4], w[5]);
  return material(m);
}

int RoomBuilder::painted() {
  const float v = rng_.uniform(0.25, 0.92);
  return plain(hsv(rng_.uniform(0, 1), rng_.uniform(0.05, 0.45), v));
}

Vec3f RoomBuilder::saturated() {
  return hsv(rng_.uniform(0, 1), rng_.uniform(0.45, 0.95), rng_.uniform(0.35, 0.95));
}

int RoomBuilder::spine() {
  Material m;
  m.pattern = Pattern::kSpine;
  m.a = hsv(rng_.uniform(0, 1), rng_.uniform(0.3, 0.9), rng_.uniform(0.2, 0.9));
  m.b = rng_.chance(0.5) ? Vec3f(0.85f, 0.75f, 0.35f) : saturated();
  m.c = rng_.chance(0.5) ? Vec3f(0.95f, 0.93f, 0.88f) : Vec3f(0.08f, 0.08f, 0.08f);
  m.variant = rng_.integer(0, 3);
  return material(m);
}

int RoomBuilder::posterMaterial(float width, float height, bool cork) {
  Material m;
  m.pattern = Pattern::kPoster;
  m.variant = cork ? 1 : 0;
  if (cork) {
    m.a = Vec3f(0.72f, 0.55f, 0.36f);
  } else {
    const float h = rng_.uniform(0, 1);
    m.a = hsv(h, rng_.uniform(0.1, 0.7), rng_.uniform(0.55, 0.98));
    m.b = hsv(h + rng_.uniform(-0.15, 0.15), rng_.uniform(0.2, 0.9), rng_.uniform(0.3, 0.9));
  }
  m.c = rng_.chance(0.7) ? Vec3f(0.08f, 0.08f, 0.1f) : Vec3f(0.95f, 0.95f, 0.95f);
  m.shapes_begin = static_cast<int>(room_.shapes.size());
  const int count = cork ? rng_.integer(5, 9) : rng_.integer(5, 12);
  for (int i = 0; i < count; ++i) {
    Shape s;
    if (cork) {  // notes and photos pinned to the board
      s.kind = Shape::kRect;
      s.rx = rng_.uniform(0.04, 0.1);
      s.ry = rng_.uniform(0.04, 0.08);
      s.colour = rng_.chance(0.4) ? Vec3f(0.97f, 0.95f, 0.6f) : saturated();
    } else {
      s.kind = static_cast<Shape::Kind>(rng_.integer(0, 4));
      s.rx = rng_.uniform(0.04, 0.28) * width;
      s.ry = s.kind == Shape::kDisc || s.kind == Shape::kRing ? s.rx
                                                              : rng_.uniform(0.04, 0.3) * height;
      s.colour = saturated();
    }
    s.x = rng_.uniform(0.1, 0.9) * width;
    s.y = rng_.uniform(cork ? 0.1 : 0.25, 0.9) * height;
    room_.shapes.push_back(s);
  }
  m.shapes_count = count;
  return material(m);
}

int RoomBuilder::painting() {
  Material m;
  m.pattern = Pattern::kPainting;
  const float h = rng_.uniform(0, 1);
  m.a = hsv(h, rng_.uniform(0.3, 0.9), rng_.uniform(0.2, 0.6));
  m.b = hsv(h + rng_.uniform(0.2, 0.5), rng_.uniform(0.3, 0.9), rng_.uniform(0.5, 0.95));
  m.c = hsv(h + rng_.uniform(0.5, 0.8), rng_.uniform(0.2, 0.8), rng_.uniform(0.6, 1.0));
  m.variant = rng_.integer(0, 1);
  return material(m);
}

int RoomBuilder::foliage() {
  Material m;
  m.pattern = Pattern::kFoliage;
  m.a = Vec3f(0.08f, 0.25f, 0.07f);
  m.b = Vec3f(0.35f, 0.6f, 0.2f);
  return material(m);
}

int RoomBuilder::speckle(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  Material m;
  m.pattern = Pattern::kSpeckle;
  m.a = a;
  m.b = b;
  m.c = c;
  return material(m);
}

// ---------------------------------------------------------------- geometry

RoomBuilder::Wall RoomBuilder::wall(int k) const {
  const float w = room_.hi.x(), d = room_.hi.y();
  switch (k) {
    case 0:
      return {{0, 0}, {1, 0}, {0, 1}, w};
    case 1:
      return {{w, 0}, {0, 1}, {-1, 0}, d};
    case 2:
      return {{w, d}, {-1, 0}, {0, -1}, w};
    default:
      return {{0, d}, {0, -1}, {1, 0}, d};
  }
}

Vec3f RoomBuilder::wallPoint(int k, float s, float w, float z) const {
  const Wall f = wall(k);
  const Eigen::Vector2f p = f.corner + s * f.tangent + w * f.normal;
  return {p.x(), p.y(), z};
}

int RoomBuilder::frontFace(int k) const {
  const Wall f = wall(k);
  return std::abs(f.normal.x()) > 0.5f ? faceIndex(0, f.normal.x() > 0)
                                       : faceIndex(1, f.normal.y() > 0);
}

int RoomBuilder::addBox(const Vec3f& lo, const Vec3f& hi, const std::array<int, 6>& faces) {
  Box box;
  box.centre = (lo + hi) * 0.5f;
  box.half = (hi - lo).cwiseAbs() * 0.5f;
  box.material = faces;
  box.id = static_cast<int>(room_.boxes.size());
  room_.boxes.push_back(box);
  return box.id;
}

int RoomBuilder::wallBox(int k, float s0, float s1, float w0, float w1, float z0, float z1, int m,
                         int front, int top) {
  auto faces = allFaces(m);
  if (front >= 0) faces[frontFace(k)] = front;
  if (top >= 0) faces[faceIndex(2, true)] = top;
  return addBox(wallPoint(k, s0, w0, z0).cwiseMin(wallPoint(k, s1, w1, z1)),
                wallPoint(k, s0, w0, z0).cwiseMax(wallPoint(k, s1, w1, z1)), faces);
}

void RoomBuilder::turnedBox(int k, float s, float w, float z, const Vec3f& half, float yaw,
                            const std::array<int, 6>& faces) {
  const Wall f = wall(k);
  const float wall_yaw = std::atan2(f.tangent.y(), f.tangent.x());
  Box box;
  box.centre = wallPoint(k, s, w, z);
  box.half = half;
  box.cos_yaw = std::cos(wall_yaw + yaw);
  box.sin_yaw = std::sin(wall_yaw + yaw);
  box.rotated = true;
  box.material = faces;
  box.id = static_cast<int>(room_.boxes.size());
  room_.boxes.push_back(box);
}

}  // namespace synthetic
}  // namespace relocalizer
