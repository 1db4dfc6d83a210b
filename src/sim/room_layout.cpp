// The room's layout: dimensions, wall finishes, furniture along the walls,
// decorations, lights, and the BVH over all boxes. Everything follows from the
// seed through synthetic::Rng, in a fixed order, so a seed always gives the
// same room.

#include <algorithm>
#include <cmath>

#include "room_bvh.h"
#include "room_furniture.h"
#include "room_layout.h"
#include "room_rearrangement.h"

namespace relocalizer {
namespace synthetic {

namespace {

// buildRoom's steps, in the order it takes them, with what furnishWalls placed.
class RoomLayout {
 public:
  explicit RoomLayout(RoomBuilder& builder)
      : b_(builder),
        rng_(builder.rng()),
        room_(builder.room()),
        furniture_(builder),
        features_(builder) {}

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
  // What furnishWalls put where, small things on the furniture included.
  FurnishingRecord record() const {
    FurnishingRecord record = record_;
    record.objects = furniture_.smallObjects();
    return record;
  }

 private:
  using Wall = RoomBuilder::Wall;
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

  RoomBuilder& b_;
  Rng& rng_;
  SyntheticRoom::Impl& room_;
  Furniture furniture_;
  WallFeatures features_;
  FurnishingRecord record_;
};

int RoomLayout::dressShell() {
  // One plain, texture-poor wall; the others patterned.
  const int plain_wall = rng_.integer(0, 3);
  bool have_brick = false;
  std::array<int, 4> wall_material{};
  for (int k = 0; k < 4; ++k) {
    Material m;
    if (k == plain_wall) {
      m.pattern = Pattern::kPlain;
      m.a = hsv(rng_.uniform(0, 1), rng_.uniform(0.03, 0.2), rng_.uniform(0.8, 0.92));
    } else if (!have_brick && rng_.chance(0.3)) {
      have_brick = true;
      m.pattern = Pattern::kBrick;
      m.a = Vec3f(0.62f, 0.32f, 0.24f);
      m.b = Vec3f(0.75f, 0.48f, 0.36f);
      m.c = Vec3f(0.82f, 0.8f, 0.76f);
    } else {
      m.pattern = Pattern::kWallpaper;
      m.variant = rng_.integer(0, 2);
      const float h = rng_.uniform(0, 1);
      m.a = hsv(h, rng_.uniform(0.1, 0.4), rng_.uniform(0.7, 0.92));
      m.b = hsv(h + rng_.uniform(-0.1, 0.1), rng_.uniform(0.3, 0.7), rng_.uniform(0.45, 0.75));
      m.c = hsv(h + rng_.uniform(0.3, 0.7), rng_.uniform(0.3, 0.8), rng_.uniform(0.3, 0.9));
      m.scale = rng_.uniform(0.12, 0.3);
    }
    wall_material[k] = b_.material(m);
  }
  Material floor;
  if (rng_.chance(0.65)) {
    floor.pattern = Pattern::kPlanks;
    const int p = rng_.integer(0, 2);
    const float tones[3][6] = {{0.72f, 0.55f, 0.36f, 0.55f, 0.38f, 0.22f},
                               {0.55f, 0.36f, 0.24f, 0.38f, 0.22f, 0.14f},
                               {0.82f, 0.72f, 0.58f, 0.66f, 0.55f, 0.42f}};
    floor.a = Vec3f(tones[p][0], tones[p][1], tones[p][2]);
    floor.b = Vec3f(tones[p][3], tones[p][4], tones[p][5]);
    floor.c = floor.b * 0.5f;
    floor.scale = rng_.uniform(0.12, 0.2);
  } else {
    floor.pattern = Pattern::kTiles;
    floor.a = hsv(rng_.uniform(0, 1), rng_.uniform(0, 0.3), rng_.uniform(0.7, 0.9));
    floor.b = hsv(rng_.uniform(0, 1), rng_.uniform(0, 0.4), rng_.uniform(0.25, 0.5));
    floor.c = Vec3f(0.5f, 0.5f, 0.48f);
    floor.scale = rng_.uniform(0.3, 0.5);
  }
  // Faces: 0 x-lo (wall 3), 1 x-hi (wall 1), 2 y-lo (wall 0), 3 y-hi (wall 2).
  room_.shell_material = {wall_material[3], wall_material[1],   wall_material[0],
                          wall_material[2], b_.material(floor), b_.plain({0.94f, 0.94f, 0.92f})};
  return plain_wall;
}

void RoomLayout::furnishWalls(int plain_wall) {
  WallPlan plan;
  plan.plain_wall = plain_wall;
  for (int c = 0; c < 4; ++c) plan.corner_used[c] = rng_.chance(0.5);
  plan.door_wall = rng_.integer(0, 3);
  plan.window_wall = (plan.door_wall + rng_.integer(1, 3)) % 4;
  plan.skirting = b_.plain({0.95f, 0.95f, 0.93f});
  for (int k = 0; k < 4; ++k) furnishWall(k, plan);
}

// A corner piece, the skirting, the door or window if this wall has one, then
// furniture along the wall and decorations where it is free.
void RoomLayout::furnishWall(int k, const WallPlan& plan) {
  const float skirting_h = 0.08f;
  const float length = b_.wall(k).length;
  // Corner k is at s = 0 of wall k and s = length of wall k - 1.
  const float start = plan.corner_used[k] ? 0.75f : 0.08f;
  const float end = length - (plan.corner_used[(k + 1) % 4] ? 0.75f : 0.08f);
  if (plan.corner_used[k]) {
    if (rng_.chance(0.6))
      features_.plant(k, 0.38f, 0.38f);
    else
      features_.floorLamp(k, 0.35f, 0.35f);
  }
  b_.wallBox(k, 0, length, 0, 0.015f, 0, skirting_h, plan.skirting);

  std::vector<Rect> blocked;
  std::vector<Interval> no_furniture;
  if (k == plan.door_wall) placeDoor(k, start, end, blocked, no_furniture);
  if (k == plan.window_wall) placeWindow(k, length, blocked, no_furniture);
  record_.walls[k] = {length, start, end, no_furniture, blocked};
  // Fewer things on the plain wall, leaving bare texture-poor stretches on purpose.
  placeFurniture(k, start, end, k == plan.plain_wall ? 2 : 4, no_furniture, blocked);
  placeDecorations(k, length, start, end,
                   k == plan.plain_wall ? 2 : static_cast<int>(length / 1.1f), blocked);
}

void RoomLayout::placeDoor(int k, float start, float end, std::vector<Rect>& blocked,
                           std::vector<Interval>& no_furniture) {
  const float w = rng_.uniform(0.82, 0.92);
  const float s0 = rng_.uniform(start + 0.15, std::max(start + 0.15, end - w - 0.15));
  const float h = rng_.uniform(2.0, 2.1);
  features_.door(k, s0, w, h);
  const Wall f = b_.wall(k);
  room_.door.centre = b_.wallPoint(k, s0 + w / 2, 0, h / 2).cast<double>();
  room_.door.inward = Eigen::Vector3d(f.normal.x(), f.normal.y(), 0);
  room_.door.width = w;
  room_.door.height = h;
  blocked.push_back({s0 - 0.1f, s0 + w + 0.1f, 0, h + 0.1f});
  no_furniture.push_back({s0 - 0.12f, s0 + w + 0.12f});
}

void RoomLayout::placeWindow(int k, float length, std::vector<Rect>& blocked,
                             std::vector<Interval>& no_furniture) {
  const float height = room_.hi.z();
  const float w = rng_.uniform(1.0, 1.6);
  const float s0 = (length - w) / 2 + rng_.uniform(-0.5, 0.5) * (length - w - 2.2f) / 2;
  const float z0 = rng_.uniform(0.85, 0.95), z1 = std::min(height - 0.3f, rng_.uniform(2.05, 2.2));
  features_.window(k, s0, w, z0, z1);
  // Curtains reach ~0.55 m either side; the radiator keeps the floor below.
  blocked.push_back({s0 - 0.55f, s0 + w + 0.55f, 0, z1 + 0.2f});
  no_furniture.push_back({s0 - 0.6f, s0 + w + 0.6f});
}

// Up to `max_items` pieces of furniture from `start`, skipping the door and
// window stretches.
void RoomLayout::placeFurniture(int k, float start, float end, int max_items,
                                const std::vector<Interval>& no_furniture,
                                std::vector<Rect>& blocked) {
  int items = 0;
  float s = start + rng_.uniform(0.0, 0.3);
  while (items < max_items && s < end - 0.6f) {
    const int kind = rng_.integer(0, 9);  // 0-2 bookshelf, 3-5 desk, 6-8 cabinet, 9 wardrobe
    float width = kind <= 2   ? rng_.uniform(0.8, 1.2)
                  : kind <= 5 ? rng_.uniform(1.0, 1.6)
                  : kind <= 8 ? rng_.uniform(0.8, 1.5)
                              : rng_.uniform(0.9, 1.2);
    width = std::min(width, end - s);
    if (width < 0.6f) break;
    bool clash = false;
    for (const Interval& i : no_furniture)
      if (i.overlaps(s, s + width)) {
        s = i.hi + 0.05f;
        clash = true;
      }
    if (clash) continue;
    float top;
    const int box_begin = static_cast<int>(room_.boxes.size());
    if (kind <= 2)
      top = furniture_.bookshelf(k, s, width);
    else if (kind <= 5)
      top = furniture_.desk(k, s, width);
    else if (kind <= 8)
      top = furniture_.cabinet(k, s, width);
    else
      top = furniture_.wardrobe(k, s, width);
    record_.furniture.push_back(
        {k, s, s + width, 0, top, box_begin, static_cast<int>(room_.boxes.size())});
    blocked.push_back(furnitureClearance(s, s + width, top));
    ++items;
    s += width + (rng_.chance(0.3) ? rng_.uniform(0.6, 1.0) : rng_.uniform(0.05, 0.35));
  }
}

// Up to `max_decor` decorations where the wall is free, mostly at eye height.
void RoomLayout::placeDecorations(int k, float length, float start, float end, int max_decor,
                                  std::vector<Rect>& blocked) {
  int decor = 0;
  for (int attempt = 0; attempt < 80 && decor < max_decor; ++attempt) {
    const auto piece = tryDecoration(b_, features_, k, {length, start, end, {}, {}}, blocked);
    if (!piece) continue;
    record_.decorations.push_back(*piece);
    ++decor;
  }
}

void RoomLayout::layRug() {
  Material rug;
  rug.pattern = Pattern::kRug;
  const float h = rng_.uniform(0, 1);
  rug.a = hsv(h, rng_.uniform(0.4, 0.8), rng_.uniform(0.4, 0.7));
  rug.b = hsv(h + 0.5f, rng_.uniform(0.2, 0.6), rng_.uniform(0.6, 0.9));
  rug.c = hsv(h + rng_.uniform(0.2, 0.35), rng_.uniform(0.5, 0.9), rng_.uniform(0.2, 0.5));
  rug.scale = rng_.uniform(0.25, 0.4);
  const int m = b_.material(rug);
  Box box;
  box.centre = Vec3f(room_.hi.x() / 2, room_.hi.y() / 2, 0.005f);
  box.half = Vec3f(rng_.uniform(1.0, 1.3), rng_.uniform(0.7, 0.9), 0.005f);
  const float yaw = rng_.uniform(-0.2, 0.2);
  box.cos_yaw = std::cos(yaw);
  box.sin_yaw = std::sin(yaw);
  box.rotated = true;
  box.material = allFaces(m);
  box.id = static_cast<int>(room_.boxes.size());
  room_.boxes.push_back(box);
}

void RoomLayout::hangLights() {
  const float height = room_.hi.z();
  const int fitting = b_.plain({1.0f, 1.0f, 0.97f});
  const std::array<Eigen::Vector2f, 2> light_xy = {
      Eigen::Vector2f(room_.hi.x() * rng_.uniform(0.3, 0.4), room_.hi.y() * rng_.uniform(0.4, 0.6)),
      Eigen::Vector2f(room_.hi.x() * rng_.uniform(0.6, 0.7),
                      room_.hi.y() * rng_.uniform(0.4, 0.6))};
  for (int i = 0; i < 2; ++i) {
    const Vec3f p(light_xy[i].x(), light_xy[i].y(), height - 0.2f);
    b_.addBox(p - Vec3f(0.2f, 0.2f, -0.15f), p + Vec3f(0.2f, 0.2f, 0.2f), allFaces(fitting));
    room_.lights[i].position = p;
    const float warm = rng_.uniform(0.0, 0.08);
    room_.lights[i].colour = Vec3f(0.62f + warm, 0.6f, 0.58f - warm);
    room_.lights[i].falloff = 0.08f;
  }
  room_.ambient = Vec3f(0.44f, 0.44f, 0.46f);
}

void RoomLayout::prepareEffects() {
  Material person;
  person.pattern = Pattern::kClothes;
  person.a = b_.saturated();
  person.b = Vec3f(0.9f, 0.9f, 0.88f);
  person.c = Vec3f(0.15f, 0.2f, 0.35f);
  person.scale = 0.06f;
  room_.person_material = b_.material(person);
  Material cart = person;
  cart.variant = 1;
  cart.a = b_.saturated();
  cart.b = Vec3f(0.1f, 0.1f, 0.1f);
  cart.scale = 0.1f;
  room_.cart_material = b_.material(cart);
  drawPathPhases(room_, rng_);
}

}  // namespace

std::optional<FurnishingRecord::Piece> tryDecoration(RoomBuilder& b, WallFeatures& features, int k,
                                                     const FurnishingRecord::Wall& wall,
                                                     std::vector<Rect>& blocked) {
  Rng& rng = b.rng();
  const float room_height = b.room().hi.z();
  const int kind = rng.integer(0, 9);  // 0-2 poster, 3-6 picture, 7 cork, 8-9 shelf
  float w, h;
  if (kind <= 2) {
    w = rng.uniform(0.4, 0.8);
    h = w * rng.uniform(1.2, 1.5);
  } else if (kind <= 6) {
    w = rng.uniform(0.4, 1.2);
    h = rng.uniform(0.35, 0.9);
  } else if (kind == 7) {
    w = rng.uniform(0.6, 1.0);
    h = rng.uniform(0.45, 0.7);
  } else {
    w = rng.uniform(0.5, 0.9);
    h = 0.45f;
  }
  const auto [sc, zc] = drawDecorationSpot(rng, room_height, w, h, wall.length);
  if (!decorationFits(room_height, sc, zc, w, h, wall.start, wall.end, blocked))
    return std::nullopt;
  const int box_begin = b.room().boxes.size();
  if (kind <= 2)
    features.poster(k, sc, zc, w, h);
  else if (kind <= 6)
    features.framedPicture(k, sc, zc, w, h);
  else if (kind == 7)
    features.corkboard(k, sc, zc, w, h);
  else
    features.wallShelf(k, sc, zc, w);
  blocked.push_back({sc - w / 2, sc + w / 2, zc - h / 2, zc + h / 2});
  return FurnishingRecord::Piece{k,
                                 sc - w / 2,
                                 sc + w / 2,
                                 zc - h / 2,
                                 zc + h / 2,
                                 box_begin,
                                 static_cast<int>(b.room().boxes.size())};
}

void buildRoom(SyntheticRoom::Impl& room) {
  Rng rng(mix64(room.appearance_seed ^ 0x5eed0f5ce9e5ULL));
  RoomBuilder b(room, rng);
  RoomLayout layout(b);
  room.lo = Vec3f::Zero();
  room.hi = Vec3f(rng.uniform(5.6, 6.4), rng.uniform(4.6, 5.4), rng.uniform(2.6, 3.0));
  const int plain_wall = layout.dressShell();
  layout.furnishWalls(plain_wall);
  layout.layRug();
  layout.hangLights();
  layout.prepareEffects();
  auto record = std::make_shared<FurnishingRecord>(layout.record());
  if (room.seed != room.appearance_seed) {
    // A generator of its own, so the appearance above is the appearance seed's room to the bit.
    Rng layout_rng(mix64(room.seed ^ 0x1a70e7a5ea7ULL));
    RoomBuilder look_alike(room, layout_rng);
    rearrange(look_alike, *record);
  }
  room.furnishing = std::move(record);
  room.nodes = buildBvh(room.boxes);
}

std::pair<float, float> drawDecorationSpot(Rng& rng, float room_height, float w, float h,
                                           float length) {
  const float sc = rng.uniform(0.15 + w / 2, length - 0.15 - w / 2);
  const float zc =
      rng.uniform(std::max(1.0f + h / 2, 1.35f), std::min(room_height - 0.25f - h / 2, 1.85f));
  return {sc, zc};
}

bool decorationFits(float room_height, float sc, float zc, float w, float h, float start, float end,
                    const std::vector<Rect>& blocked) {
  if (!(zc - h / 2 >= 0.9f && zc + h / 2 <= room_height - 0.2f)) return false;
  const Rect r{sc - w / 2 - 0.08f, sc + w / 2 + 0.08f, zc - h / 2 - 0.08f, zc + h / 2 + 0.08f};
  bool free = r.s0 > start - 0.7f && r.s1 < end + 0.7f;
  for (const Rect& o : blocked)
    free = free && !(r.s0 < o.s1 && r.s1 > o.s0 && r.z0 < o.z1 && r.z1 > o.z0);
  return free;
}

void drawPathPhases(SyntheticRoom::Impl& room, Rng& rng) {
  room.path_phase = rng.uniform(0, kTwoPi);
  for (double& p : room.phases) p = rng.uniform(0, kTwoPi);
}

}  // namespace synthetic
}  // namespace relocalizer
