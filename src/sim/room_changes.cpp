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

// What the test frames of synthesize's default split (SyntheticSceneOptions)
// see, so that the changes go where they show: a coarse grid of rays from
// every 5th frame, and what each meets first.
struct TestSight {
  std::vector<Pose> path;             // the default test path
  int first_time = 0;                 // its first frame's time
  std::vector<int> box_hits;          // by box id
  std::array<int, 4> wall_hits = {};  // hits nearest wall k (RoomBuilder's numbering)
};

TestSight testSight(const SyntheticRoom::Impl& room) {
  const SyntheticSceneOptions defaults;
  TestSight sight;
  sight.path = roomTrajectories(room, defaults.train_frames, defaults.test_frames).test;
  sight.first_time = defaults.train_frames;
  sight.box_hits.assign(room.boxes.size(), 0);
  const CameraIntrinsics grid = CameraIntrinsics::kinectDefault().scaledTo(32, 24);
  for (size_t j = 0; j < sight.path.size(); j += 5) {
    const Eigen::Matrix3f rotation = sight.path[j].linear().cast<float>();
    const Vec3f origin = sight.path[j].translation().cast<float>();
    for (int v = 0; v < grid.height; ++v)
      for (int u = 0; u < grid.width; ++u) {
        const Ray ray(origin, rotation * Vec3f(static_cast<float>((u - grid.cx) / grid.fx),
                                               static_cast<float>((v - grid.cy) / grid.fy), 1.0f));
        const Hit hit = room.trace(ray, nullptr);
        if (!std::isfinite(hit.t)) continue;
        if (hit.box >= 0) ++sight.box_hits[hit.id];
        const Vec3f p = ray.o + hit.t * ray.d;
        // Walls 0-3 run along y = 0, x = max, y = max and x = 0.
        const std::array<float, 4> away = {p.y() - room.lo.y(), room.hi.x() - p.x(),
                                           room.hi.y() - p.y(), p.x() - room.lo.x()};
        ++sight.wall_hits[std::min_element(away.begin(), away.end()) - away.begin()];
      }
  }
  return sight;
}

using BoxRange = std::pair<int, int>;  // boxes [first, second)

std::vector<BoxRange> boxRanges(const std::vector<FurnishingRecord::Piece>& pieces) {
  std::vector<BoxRange> ranges;
  for (const FurnishingRecord::Piece& piece : pieces)
    ranges.emplace_back(piece.box_begin, piece.box_end);
  return ranges;
}

// Indices of `things` in a random order drawn from `rng`, those the test
// frames see most first.
std::vector<int> mostSeenFirst(const std::vector<BoxRange>& things, const TestSight& sight,
                               Rng& rng) {
  std::vector<int> order(things.size()), hits(things.size(), 0);
  std::iota(order.begin(), order.end(), 0);
  for (int i = static_cast<int>(order.size()) - 1; i > 0; --i)
    std::swap(order[i], order[rng.integer(0, i)]);
  for (size_t i = 0; i < things.size(); ++i)
    for (int b = things[i].first; b < things[i].second; ++b) hits[i] += sight.box_hits[b];
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return hits[a] > hits[b]; });
  return order;
}

// Takes `count` wall decorations and small things on the furniture away with
// their boxes, those the test frames see most first, and renumbers the boxes
// left (ids and the record's box ranges) in their order; returns how many it took.
int removeObjects(SyntheticRoom::Impl& room, FurnishingRecord& record, const TestSight& sight,
                  int count, Rng& rng) {
  std::vector<BoxRange> things = boxRanges(record.decorations);  // then the small objects
  const size_t decorations = things.size();
  things.insert(things.end(), record.objects.begin(), record.objects.end());
  std::vector<int> order = mostSeenFirst(things, sight, rng);
  order.resize(std::min<size_t>(order.size(), count));
  std::vector<bool> gone(room.boxes.size(), false), taken(things.size(), false);
  for (const int i : order) {
    taken[i] = true;
    for (int b = things[i].first; b < things[i].second; ++b) gone[b] = true;
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
  std::vector<FurnishingRecord::Piece> kept_decorations;
  std::vector<BoxRange> kept_objects;
  for (size_t i = 0; i < things.size(); ++i) {
    if (taken[i]) continue;
    if (i < decorations)
      kept_decorations.push_back(record.decorations[i]);
    else
      kept_objects.push_back(things[i]);
  }
  record.decorations = std::move(kept_decorations);
  record.objects = std::move(kept_objects);
  for (auto* pieces : {&record.furniture, &record.decorations})
    for (FurnishingRecord::Piece& piece : *pieces) {
      piece.box_begin = new_index[piece.box_begin];
      piece.box_end = new_index[piece.box_end];
    }
  for (BoxRange& object : record.objects)
    object = {new_index[object.first], new_index[object.second]};
  return static_cast<int>(order.size());
}

// Up to `count` new decorations where the walls are free of the door, the
// window, the furniture and the other decorations; returns how many.
int addDecorations(RoomBuilder& b, FurnishingRecord& record, const TestSight& sight, int count) {
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
  const int total = std::accumulate(sight.wall_hits.begin(), sight.wall_hits.end(), 4);
  int added = 0;
  for (int attempt = 0; added < count && attempt < kDecorationAttempts; ++attempt) {
    // Walls the test frames see more, more often, until half the tries
    // failed (those walls are full); then any wall.
    int k = 0;
    if (attempt < kDecorationAttempts / 2) {
      for (int pick = b.rng().integer(0, total - 1); pick >= sight.wall_hits[k] + 1; ++k)
        pick -= sight.wall_hits[k] + 1;
    } else {
      k = b.rng().integer(0, 3);
    }
    const auto piece = tryDecoration(b, features, k, record.walls[k], blocked[k]);
    if (!piece) continue;
    record.decorations.push_back(*piece);
    ++added;
  }
  return added;
}

// One ceiling light off, or a lamp on: a warm light at 1.2 m, 0.4 m out from
// what the test camera faces half-way along its path, falling off fast, so it lights a few
// square metres of wall and what stands there. Needs the room's BVH. Returns
// whether it switched one (a room can hold one lamp more).
bool switchLamp(RoomBuilder& b, const TestSight& sight, LampChange lamp) {
  SyntheticRoom::Impl& room = b.room();
  if (lamp == LampChange::kOff) {
    room.lights[b.rng().integer(0, 1)].colour = Vec3f::Zero();
    return true;
  }
  if (lamp == LampChange::kOn && room.light_count < SyntheticRoom::Impl::kMaxLights) {
    const Pose& view = sight.path[sight.path.size() / 2];
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
    return true;
  }
  return false;
}

// Where on a walker's ellipse (its angle) the ray from `view` straight ahead
// meets it, for a view inside the ellipse.
double angleAhead(const SyntheticRoom::Impl& room, float inset, const Pose& view) {
  const Eigen::Vector2d centre = ((room.lo + room.hi) / 2).head<2>().cast<double>();
  const Eigen::Vector2d radii = ((room.hi - room.lo) / 2).head<2>().cast<double>().array() - inset;
  const Eigen::Vector2d o = (view.translation().head<2>() - centre).cwiseQuotient(radii);
  const Eigen::Vector2d d = view.linear().col(2).head<2>().cwiseQuotient(radii);
  // |o + s d| = 1, s > 0.
  const double a = d.squaredNorm(), half_b = o.dot(d), c = o.squaredNorm() - 1;
  const double s = (-half_b + std::sqrt(std::max(half_b * half_b - a * c, 0.0))) / a;
  const Eigen::Vector2d p = o + s * d;
  return std::atan2(p.y(), p.x());
}

// People in clothes of their own going round the free floor as the moving
// person does (room_effects.cpp), some each way, a little nearer to or further
// from the walls, at walking pace (1-1.5 rad/s round the room at 30 Hz). Each
// walks through the middle of the test camera's view once, the first early in
// the test path, the last late.
void addPeople(RoomBuilder& b, const TestSight& sight, int count) {
  SyntheticRoom::Impl& room = b.room();
  Rng& rng = b.rng();
  // A frame holds at most kMaxPeople besides the moving objects, however
  // often a room is changed.
  count = std::min(count, SceneChanges::kMaxPeople - static_cast<int>(room.people.size()));
  for (int i = 0; i < count; ++i) {
    Material clothes = room.materials[room.person_material];
    clothes.a = b.saturated();
    SyntheticRoom::Impl::Walker person;
    person.material = b.material(clothes);
    person.speed = (i % 2 == 0 ? 1 : -1) * rng.uniform(0.010, 0.016);
    person.inset = rng.uniform(0.8, 1.1);
    person.half = Vec3f(rng.uniform(0.17, 0.23), rng.uniform(0.1, 0.14), rng.uniform(0.78, 0.92));
    const int seen_at = static_cast<int>((i + rng.uniform(0.2, 0.8)) * sight.path.size() / count);
    person.phase = angleAhead(room, person.inset, sight.path[seen_at]) -
                   person.speed * (sight.first_time + seen_at);
    room.people.push_back(person);
  }
}

}  // namespace

void applyChanges(SyntheticRoom::Impl& room, const SceneChanges& changes) {
  const TestSight sight = testSight(room);  // with the room's BVH, before it changes
  // The record's box ranges are creation order; the BVH has reordered the boxes.
  std::sort(room.boxes.begin(), room.boxes.end(),
            [](const Box& a, const Box& b) { return a.id < b.id; });
  auto record = std::make_shared<FurnishingRecord>(*room.furnishing);
  Rng moves = changeRng(room, 1), removals = changeRng(room, 2), additions = changeRng(room, 3),
      lamp = changeRng(room, 4), people = changeRng(room, 5);
  SceneChanges& made = room.changes;
  RoomBuilder mover(room, moves);
  made.moved_furniture +=
      moveFurniture(mover, *record, mostSeenFirst(boxRanges(record->furniture), sight, moves),
                    changes.moved_furniture);
  made.removed_objects += removeObjects(room, *record, sight, changes.removed_objects, removals);
  RoomBuilder adder(room, additions);
  made.added_objects += addDecorations(adder, *record, sight, changes.added_objects);
  RoomBuilder walkers(room, people);
  addPeople(walkers, sight, changes.people);
  made.people = static_cast<int>(room.people.size());
  room.furnishing = std::move(record);
  room.nodes = buildBvh(room.boxes);
  RoomBuilder switcher(room, lamp);
  if (switchLamp(switcher, sight, changes.lamp)) made.lamp = changes.lamp;
}

}  // namespace synthetic
}  // namespace relocalizer
