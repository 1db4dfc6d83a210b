#pragma once
// Internals of the synthetic room shared by its source files: deterministic
// randomness, materials, boxes and the room data. Not installed, not API.
//
// room_layout.cpp builds a room from its seed (room_builder.h: materials and
// boxes; room_furniture.h, room_wall_features.h: the pieces made of them;
// room_layout.h, room_rearrangement.h: where they go, and a look-alike's
// layout; room_bvh.h: the BVH), synthetic_textures.h colours its surfaces,
// room_effects.h varies its lighting and moving objects frame by frame,
// room_trajectories.h plans camera paths, synthetic_room.cpp ray casts and
// renders, synthetic_scene.cpp writes datasets.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "relocalizer/sim/synthetic_scene.h"

namespace relocalizer {
namespace synthetic {

using Vec3f = Eigen::Vector3f;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kTwoPi = 6.28318530717958647692f;
constexpr int kNoFace = -1;

// ---------------------------------------------------------------- randomness
//
// Everything random comes from the room's seed through these hashes and a
// private generator, never from std:: random distributions (their output
// differs between standard libraries) or time.

// splitmix64: tiny, fast and identical on every platform.
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  float uniform(double lo, double hi) { return static_cast<float>(lo + (hi - lo) * uniform()); }
  int integer(int lo, int hi) {  // inclusive
    return lo + static_cast<int>(next() % static_cast<uint64_t>(hi - lo + 1));
  }
  bool chance(double p) { return uniform() < p; }
  uint32_t seed32() { return static_cast<uint32_t>(next() >> 32); }

 private:
  uint64_t state_;
};

inline uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

inline uint32_t mix32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

// One finaliser over a linear mix: collisions need |x|, |y| ~ 1e9 lattice cells.
inline uint32_t hashCell(int x, int y, uint32_t seed) {
  return mix32(static_cast<uint32_t>(x) * 0x8da6b343U + static_cast<uint32_t>(y) * 0xd8163841U +
               seed * 0x9E3779B9U);
}

inline float unitFloat(uint32_t h) { return static_cast<float>(h >> 8) * (1.0f / 16777216.0f); }

inline float smooth01(float t) { return t * t * (3.0f - 2.0f * t); }
inline float smoothstep(float e0, float e1, float x) {
  return smooth01(std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f));
}
// floor() without a libm call on baseline x86-64 (no SSE4.1 round instruction).
inline int floorInt(float x) {
  const int i = static_cast<int>(x);
  return i - (x < static_cast<float>(i) ? 1 : 0);
}

inline float fract(float x) { return x - static_cast<float>(floorInt(x)); }
inline Vec3f mix(const Vec3f& a, const Vec3f& b, float t) { return a + (b - a) * t; }

inline float valueNoise(float x, float y, uint32_t seed) {
  const int ix = floorInt(x), iy = floorInt(y);
  const float fx = static_cast<float>(ix), fy = static_cast<float>(iy);
  const float tx = smooth01(x - fx), ty = smooth01(y - fy);
  const float a = unitFloat(hashCell(ix, iy, seed));
  const float b = unitFloat(hashCell(ix + 1, iy, seed));
  const float c = unitFloat(hashCell(ix, iy + 1, seed));
  const float d = unitFloat(hashCell(ix + 1, iy + 1, seed));
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * ty;
}

// Multi-octave value noise in [0, 1]; the odd lacunarity keeps octave lattices
// from lining up into visible grid artefacts.
inline float fbm(float x, float y, uint32_t seed, int octaves) {
  float sum = 0.0f, amplitude = 0.5f, norm = 0.0f;
  for (int i = 0; i < octaves; ++i) {
    sum += amplitude * valueNoise(x, y, seed + static_cast<uint32_t>(i) * 0x9E3779B9U);
    norm += amplitude;
    x = x * 2.03f + 17.1f;
    y = y * 2.03f + 5.3f;
    amplitude *= 0.5f;
  }
  return sum / norm;
}

// ---------------------------------------------------------------- materials

enum class Pattern : uint8_t {
  kPlain,      // texture-poor paint
  kWallpaper,  // stripes, lattice or sponged paint (variant)
  kBrick,
  kPlanks,  // floorboards
  kWood,    // furniture grain along the face's long side
  kTiles,
  kPoster,    // random shapes and text lines (variant 1: cork board with notes)
  kPainting,  // domain-warped noise through a palette
  kSpine,     // book spine: bands and a title block across the long side
  kRug,
  kSky,      // view through a window
  kScreen,   // switched-off display: dark enough to lose depth
  kClothes,  // moving distractors
  kFoliage,
  kSpeckle,  // granite, laminate
  kRadiator,
  kCurtain,
};

struct Material {
  Pattern pattern = Pattern::kPlain;
  Vec3f a{0.8f, 0.8f, 0.8f}, b{0.6f, 0.6f, 0.6f}, c{0.2f, 0.2f, 0.2f};
  float scale = 0.1f;  // metres per pattern period
  uint32_t seed = 0;
  int variant = 0;
  int shapes_begin = 0, shapes_count = 0;
  // False for glass: the Kinect's infrared pattern passes through it.
  bool gives_depth = true;
};

// Poster elements in metres from the face's (u, v) origin.
struct Shape {
  enum Kind : uint8_t { kDisc, kRect, kTriangle, kRing, kDiamond } kind = kRect;
  float x = 0, y = 0, rx = 0, ry = 0;
  Vec3f colour{0, 0, 0};
};

// ---------------------------------------------------------------- geometry

// Face index: 2 * axis + 1 for the face on the +axis side.
inline int faceIndex(int axis, bool positive_side) { return 2 * axis + (positive_side ? 1 : 0); }
// The in-face (u, v) axes; v is up on vertical faces so text and bands are upright.
constexpr int kFaceU[3] = {1, 0, 0};
constexpr int kFaceV[3] = {2, 2, 1};

// A box, optionally turned about the vertical axis by its yaw.
struct Box {
  Vec3f centre{0, 0, 0}, half{0, 0, 0};
  float cos_yaw = 1.0f, sin_yaw = 0.0f;
  bool rotated = false;
  int id = 0;  // creation order: breaks exact ties so hits never depend on BVH layout
  std::array<int, 6> material{};

  Vec3f toLocal(const Vec3f& p) const {  // p relative to the centre
    return rotated
               ? Vec3f(cos_yaw * p.x() + sin_yaw * p.y(), -sin_yaw * p.x() + cos_yaw * p.y(), p.z())
               : p;
  }
  Vec3f toWorld(const Vec3f& p) const {
    return rotated
               ? Vec3f(cos_yaw * p.x() - sin_yaw * p.y(), sin_yaw * p.x() + cos_yaw * p.y(), p.z())
               : p;
  }
  void worldBounds(Vec3f& lo, Vec3f& hi) const {
    const Vec3f extent(std::abs(cos_yaw) * half.x() + std::abs(sin_yaw) * half.y(),
                       std::abs(sin_yaw) * half.x() + std::abs(cos_yaw) * half.y(), half.z());
    lo = centre - extent;
    hi = centre + extent;
  }
};

// The BVH that rays traverse: four children per node with their bounds stored
// lane by lane, so one short loop tests all four (the compiler vectorises it)
// and trees are half as deep as binary ones.
struct WideNode {
  alignas(16) float lo[3][4];
  alignas(16) float hi[3][4];
  int child[4];  // inner child: node index; leaf child: first box
  int count[4];  // leaf child: number of boxes (1-4); inner child: 0; empty slot: -1
};

struct Ray {
  Vec3f o, d, inv;
  Ray(const Vec3f& origin, const Vec3f& direction)
      : o(origin), d(direction), inv(direction.cwiseInverse()) {}
};

struct Hit {
  float t = kInf;
  int box = -1;  // -1: room shell; >= 0: static box; <= -2: moving box -2 - k
  int face = kNoFace;
  int id = std::numeric_limits<int>::max();
};

constexpr float kHitEpsilon = 1e-5f;

// Entry hit of a ray starting outside the box; rays from inside ignore it.
inline bool intersectBox(const Box& box, const Ray& r, float& t, int& face) {
  Vec3f o = r.o - box.centre;
  Vec3f d = r.d, inv = r.inv;
  if (box.rotated) {
    o = box.toLocal(o);
    d = box.toLocal(d);
    inv = d.cwiseInverse();
  }
  float t_near = -kInf, t_far = kInf;
  int axis = 0;
  for (int k = 0; k < 3; ++k) {
    float t0 = (-box.half[k] - o[k]) * inv[k];
    float t1 = (box.half[k] - o[k]) * inv[k];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_near) {
      t_near = t0;
      axis = k;
    }
    t_far = std::min(t_far, t1);
  }
  if (!(t_near <= t_far) || t_near <= kHitEpsilon) return false;
  t = t_near;
  face = faceIndex(axis, d[axis] < 0.0f);
  return true;
}

inline float boxDistance(const Box& box, const Vec3f& p) {
  const Vec3f q = box.toLocal(p - box.centre).cwiseAbs() - box.half;
  const float outside = q.cwiseMax(0.0f).norm();
  const float inside = std::min(q.maxCoeff(), 0.0f);
  return std::abs(outside + inside);
}

inline std::array<int, 6> allFaces(int material) {
  return {material, material, material, material, material, material};
}

struct FurnishingRecord;  // room_layout.h

}  // namespace synthetic

// ---------------------------------------------------------------- the room

struct SyntheticRoom::Impl {
  using Vec3f = synthetic::Vec3f;
  using Material = synthetic::Material;
  using Shape = synthetic::Shape;
  using Box = synthetic::Box;
  using WideNode = synthetic::WideNode;
  using Ray = synthetic::Ray;
  using Hit = synthetic::Hit;

  struct Light {
    Vec3f position;
    Vec3f colour;          // intensity per channel
    float falloff = 0.1f;  // 1 / (1 + falloff * d^2)
  };
  static constexpr int kMaxLights = 3;  // two ceiling lights and a changed room's lamp
  // Someone or something going round the free floor, `inset` in from the
  // walls, at `speed` radians per frame from `phase` (room_effects.cpp).
  struct Walker {
    double phase = 0, speed = 0;
    float inset = 0.85f;
    Vec3f half{0, 0, 0};
    int material = 0;
  };
  static constexpr int kMaxMovers = 2 + SceneChanges::kMaxPeople;

  uint64_t seed = 0;             // the layout's seed, and the renders' (depth noise)
  uint64_t appearance_seed = 0;  // materials and pieces; == seed but in a look-alike room
  Vec3f lo{0, 0, 0}, hi{6, 5, 2.8f};
  std::array<int, 6> shell_material{};
  std::vector<Material> materials;
  std::vector<Shape> shapes;
  std::vector<Box> boxes;
  std::vector<WideNode> nodes;
  std::array<Light, kMaxLights> lights{};
  int light_count = 2;
  Vec3f ambient{0.4f, 0.4f, 0.4f};
  RoomDoor door;  // recorded by the layout's placeDoor; draws nothing
  double path_phase = 0.0;
  std::array<double, 8> phases{};  // of path wobbles and time-varying effects
  int person_material = 0, cart_material = 0;
  std::vector<Walker> people;  // a changed room's (SceneChanges::people)
  SceneChanges changes;        // what changed() made of this room
  // What stands where along the walls (room_layout.h), so a changed room can
  // move, take away and add pieces.
  std::shared_ptr<const synthetic::FurnishingRecord> furnishing;

  // Per-frame lighting and distractors.
  struct FrameState {
    Vec3f ambient;
    std::array<Vec3f, kMaxLights> light_colour;
    Vec3f gain;
    std::array<Box, kMaxMovers> movers;
    int mover_count = 0;
  };

  Hit trace(const Ray& ray, const FrameState* frame) const;
  const Box& hitBox(const Hit& hit, const FrameState* frame) const {
    return hit.box >= 0 ? boxes[hit.box] : frame->movers[-2 - hit.box];
  }
  // Colour (linear, unclamped) of what a ray hits, given the hit.
  Vec3f shade(const Ray& ray, const Hit& hit, const FrameState& frame, bool& gives_depth) const;
};

namespace synthetic {
// Fills in a room from its seeds (walls, furniture, lights, BVH): the room of
// appearance_seed, with its furniture and decorations rearranged by seed when
// the two differ.
void buildRoom(SyntheticRoom::Impl& room);
}  // namespace synthetic

}  // namespace relocalizer
