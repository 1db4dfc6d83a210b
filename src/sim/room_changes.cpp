// A room changed after training: each change draws from a generator of its
// own, seeded by the room's seed, so one change's count never alters another.

#include "room_changes.h"

#include <numeric>

#include "room_bvh.h"
#include "room_layout.h"
#include "room_rearrangement.h"
#include "room_trajectories.h"

namespace relocalizer {
namespace synthetic {
namespace {

// Tries at hanging each new decoration somewhere on the walls before giving up
// on it (the walls are full).
constexpr int kDecorationAttempts = 400;
// How far the lamp switched on stands out from what it lights (metres).
constexpr float kLampFromWall = 0.4f;
// A wall whose furniture stays further than this from a corner has a corner piece there.
constexpr float kCornerPieceClearance = 0.5f;

Rng changeRng(const SyntheticRoom::Impl& room, uint64_t change) {
  return Rng(mix64(room.seed ^ mix64(0xc4a93ed0000ULL + change)));
}

// Drops `count` decorations drawn from `rng` with their boxes, and renumbers
// the boxes left (ids and the record's box ranges) in their order.
void removeDecorations(SyntheticRoom::Impl& room, FurnishingRecord& record, int count, Rng& rng) {
  std::vector<int> order(record.decorations.size());
  std::iota(order.begin(), order.end(), 0);
  for (int i = static_cast<int>(order.size()) - 1; i > 0; --i)
    std::swap(order[i], order[rng.integer(0, i)]);
  order.resize(std::min<size_t>(order.size(), count));
  std::vector<bool> gone(room.boxes.size(), false), dropped(record.decorations.size(), false);
  for (const int i : order) {
    dropped[i] = true;
    for (int b = record.decorations[i].box_begin; b < record.decorations[i].box_end; ++b)
      gone[b] = true;
  }
  std::vector<int> new_index(room.boxes.size() + 1, 0);  // of box b; [size]: the count kept
  std::vector<Box> kept;
  for (size_t b = 0; b < room.boxes.size(); ++b) {
    new_index[b] = static_cast<int>(kept.size());
    if (gone[b]) continue;
    kept.push_back(room.boxes[b]);
    kept.back().id = new_index[b];
  }
  new_index.back() = static_cast<int>(kept.size());
  room.boxes = std::move(kept);
  std::vector<FurnishingRecord::Piece> decorations;
  for (size_t i = 0; i < record.decorations.size(); ++i)
    if (!dropped[i]) decorations.push_back(record.decorations[i]);
  record.decorations = std::move(decorations);
  for (auto* pieces : {&record.furniture, &record.decorations})
    for (FurnishingRecord::Piece& piece : *pieces) {
      piece.box_begin = new_index[piece.box_begin];
      piece.box_end = new_index[piece.box_end];
    }
}

// `count` new decorations where the walls are free of the door, the window,
// the furniture and the other decorations.
void addDecorations(RoomBuilder& b, FurnishingRecord& record, int count) {
  std::array<std::vector<Rect>, 4> blocked;
  for (int k = 0; k < 4; ++k) {
    const FurnishingRecord::Wall& w = record.walls[k];
    blocked[k] = w.fixed;
    // A plant or floor lamp in a corner keeps furniture 0.75 m off (room_layout.cpp)
    // and stands up to 1.8 m high.
    if (w.start > kCornerPieceClearance) blocked[k].push_back({-1.0f, w.start, 0, 1.9f});
    if (w.length - w.end > kCornerPieceClearance)
      blocked[k].push_back({w.end, w.length + 1.0f, 0, 1.9f});
  }
  for (const FurnishingRecord::Piece& p : record.furniture)
    blocked[p.wall].push_back(furnitureClearance(p.s0, p.s1, p.z1));
  for (const FurnishingRecord::Piece& p : record.decorations)
    blocked[p.wall].push_back({p.s0, p.s1, p.z0, p.z1});
  WallFeatures features(b);
  for (int added = 0, attempt = 0; added < count && attempt < kDecorationAttempts; ++attempt) {
    const int k = b.rng().integer(0, 3);
    const auto piece = tryDecoration(b, features, k, record.walls[k], blocked[k]);
    if (!piece) continue;
    record.decorations.push_back(*piece);
    ++added;
  }
}

// One ceiling light off, or a lamp on: a warm light at 1.2 m, 0.4 m out from
// what the test camera faces half-way along its path (of synthesize's default
// 300 training and 100 test frames), falling off fast, so it lights a few
// square metres of wall and what stands there. Needs the room's BVH.
void switchLamp(RoomBuilder& b, LampChange lamp) {
  SyntheticRoom::Impl& room = b.room();
  if (lamp == LampChange::kOff) {
    room.lights[b.rng().integer(0, 1)].colour = Vec3f::Zero();
  } else if (lamp == LampChange::kOn && room.light_count < SyntheticRoom::Impl::kMaxLights) {
    const Pose view = roomTrajectories(room, 300, 100).test[50];
    Vec3f ahead = view.linear().col(2).cast<float>();
    ahead.z() = 0;
    const Vec3f from(view.translation().x(), view.translation().y(), 1.2f);
    // Before the first surface ahead (wall or furniture): lit from inside a
    // wardrobe, nothing would show.
    const float t = room.trace(Ray(from, ahead.normalized()), nullptr).t;
    const Vec3f at = from + std::max(t - kLampFromWall, t / 2) * ahead.normalized();
    SyntheticRoom::Impl::Light& light = room.lights[room.light_count++];
    light.position = at;
    light.colour = Vec3f(1.5f, 1.17f, 0.75f);
    light.falloff = 3.0f;
  }
}

// People in clothes of their own going round the free floor as the moving
// person does (room_effects.cpp), some each way, a little nearer to or further
// from the walls, at walking pace (1-1.5 rad/s round the room at 30 Hz).
void addPeople(RoomBuilder& b, int count) {
  SyntheticRoom::Impl& room = b.room();
  Rng& rng = b.rng();
  for (int i = 0; i < count; ++i) {
    Material clothes = room.materials[room.person_material];
    clothes.a = b.saturated();
    SyntheticRoom::Impl::Walker person;
    person.material = b.material(clothes);
    person.phase = rng.uniform(0, kTwoPi);
    person.speed = (i % 2 == 0 ? 1 : -1) * rng.uniform(0.010, 0.016);
    person.inset = rng.uniform(0.8, 1.1);
    person.half = Vec3f(rng.uniform(0.17, 0.23), rng.uniform(0.1, 0.14), rng.uniform(0.78, 0.92));
    room.people.push_back(person);
  }
}

}  // namespace

void applyChanges(SyntheticRoom::Impl& room, const SceneChanges& changes) {
  // The record's box ranges are creation order; the BVH has reordered the boxes.
  std::sort(room.boxes.begin(), room.boxes.end(),
            [](const Box& a, const Box& b) { return a.id < b.id; });
  auto record = std::make_shared<FurnishingRecord>(*room.furnishing);
  Rng moves = changeRng(room, 1), removals = changeRng(room, 2), additions = changeRng(room, 3),
      lamp = changeRng(room, 4), people = changeRng(room, 5);
  RoomBuilder mover(room, moves);
  moveFurniture(mover, *record, changes.moved_furniture);
  removeDecorations(room, *record, changes.removed_objects, removals);
  RoomBuilder adder(room, additions);
  addDecorations(adder, *record, changes.added_objects);
  RoomBuilder walkers(room, people);
  addPeople(walkers, changes.people);
  room.furnishing = std::move(record);
  room.nodes = buildBvh(room.boxes);
  RoomBuilder switcher(room, lamp);
  switchLamp(switcher, changes.lamp);
}

}  // namespace synthetic
}  // namespace relocalizer
