// A look-alike room's layout: the furniture and decorations another seed's
// room put along its walls, placed elsewhere along the same walls.

#include <algorithm>
#include <numeric>
#include <tuple>

#include "room_rearrangement.h"

namespace relocalizer {
namespace synthetic {
namespace {

// placeFurniture's smallest gap between neighbouring pieces.
constexpr float kFurnitureGap = 0.05f;
// Tries at finding every piece of furniture a place before the best try wins.
constexpr int kFurnitureAttempts = 32;
// Decorations are small beside the walls' free stretches, so this many random
// spots all failing means the walls are full, not unlucky.
constexpr int kDecorationAttempts = 400;
// How far a changed room's moved furniture goes at least (metres).
constexpr float kLeastFurnitureMove = 0.5f;

// `free` without (a, b).
void cut(std::vector<Interval>& free, float a, float b) {
  std::vector<Interval> next;
  for (const Interval& f : free) {
    if (f.lo <= a) next.push_back({f.lo, std::min(f.hi, a)});
    if (f.hi >= b) next.push_back({std::max(f.lo, b), f.hi});
  }
  free.swap(next);
}

// Where a piece `width` wide may start within [lo, hi] without coming within
// `gap` of what `taken` holds.
std::vector<Interval> freeStarts(float lo, float hi, float width,
                                 const std::vector<Interval>& taken, float gap) {
  std::vector<Interval> free;
  if (hi - width >= lo) free.push_back({lo, hi - width});
  // Starts strictly between clash.
  for (const Interval& t : taken) cut(free, t.lo - width - gap, t.hi + gap);
  return free;
}

// A point drawn uniformly over non-empty `intervals`.
float drawFrom(const std::vector<Interval>& intervals, Rng& rng) {
  float total = 0;
  for (const Interval& i : intervals) total += i.hi - i.lo;
  float x = rng.uniform(0, total);
  for (const Interval& i : intervals) {
    if (x <= i.hi - i.lo) return i.lo + x;
    x -= i.hi - i.lo;
  }
  return intervals.back().hi;
}

// rearrange (room_rearrangement.h), step by step, over one builder's room and generator.
class Rearrangement {
 public:
  explicit Rearrangement(RoomBuilder& builder)
      : b_(builder), rng_(builder.rng()), room_(builder.room()) {}

  void rearrange(FurnishingRecord& record);
  int moveFurniture(FurnishingRecord& record, const std::vector<int>& order, int count);

 private:
  using Wall = RoomBuilder::Wall;
  void rearrangeFurniture(FurnishingRecord& record, std::array<std::vector<Rect>, 4>& blocked);
  // Furniture standing on each wall: where it is and how far it reaches out.
  struct Placed {
    float s0, s1, depth;
  };
  using PlacedFurniture = std::array<std::vector<Placed>, 4>;
  // Where a piece reaching `reach` into the room must not start on wall k:
  // the door and window, the pieces there, and those on the neighbouring
  // walls that it would meet in a corner.
  std::vector<Interval> taken(const FurnishingRecord& record, const PlacedFurniture& placed, int k,
                              float reach) const;
  // Where each piece of furniture may go, drawn afresh; wall -1 for a piece
  // that found no room. `depths`: how far each piece reaches into the room.
  struct Spot {
    int wall;
    float s;
  };
  std::vector<Spot> tryPlacingFurniture(const FurnishingRecord& record,
                                        const std::vector<float>& depths);
  void rearrangeDecorations(FurnishingRecord& record, std::array<std::vector<Rect>, 4>& blocked);
  // The one motion: `piece`'s boxes from s = piece.s0 on its wall to s = to_s
  // on wall `to`, raised by dz; the piece then records where it is.
  void movePiece(FurnishingRecord::Piece& piece, int to, float to_s, float dz);
  // How far a piece reaches out from its wall, where it stands now.
  float reach(const FurnishingRecord::Piece& piece) const;

  RoomBuilder& b_;
  Rng& rng_;
  SyntheticRoom::Impl& room_;
};

}  // namespace

void rearrange(RoomBuilder& builder, FurnishingRecord& record) {
  Rearrangement(builder).rearrange(record);
}

int moveFurniture(RoomBuilder& builder, FurnishingRecord& record, const std::vector<int>& order,
                  int count) {
  return Rearrangement(builder).moveFurniture(record, order, count);
}

void Rearrangement::rearrange(FurnishingRecord& record) {
  std::array<std::vector<Rect>, 4> blocked;
  rearrangeFurniture(record, blocked);
  rearrangeDecorations(record, blocked);
  // Paths of their own too, so the look-alike is not filmed from the other room's poses.
  drawPathPhases(room_, rng_);
}

void Rearrangement::rearrangeFurniture(FurnishingRecord& record,
                                       std::array<std::vector<Rect>, 4>& blocked) {
  std::vector<float> depths;
  for (const FurnishingRecord::Piece& piece : record.furniture) depths.push_back(reach(piece));
  // The walls held every piece once, so a few tries find them all room again.
  std::vector<Spot> best;
  long missing_in_best = -1;
  for (int attempt = 0; attempt < kFurnitureAttempts && missing_in_best != 0; ++attempt) {
    std::vector<Spot> spots = tryPlacingFurniture(record, depths);
    const long missing =
        std::count_if(spots.begin(), spots.end(), [](const Spot& spot) { return spot.wall < 0; });
    if (missing_in_best < 0 || missing < missing_in_best) {
      best = std::move(spots);
      missing_in_best = missing;
    }
  }
  for (int k = 0; k < 4; ++k) blocked[k] = record.walls[k].fixed;
  for (size_t i = 0; i < best.size(); ++i) {
    FurnishingRecord::Piece& piece = record.furniture[i];
    // A piece that found no room stays where it was.
    const Spot spot = best[i].wall >= 0 ? best[i] : Spot{piece.wall, piece.s0};
    blocked[spot.wall].push_back(
        furnitureClearance(spot.s, spot.s + piece.s1 - piece.s0, piece.z1));
    movePiece(piece, spot.wall, spot.s, 0);
  }
}

std::vector<Rearrangement::Spot> Rearrangement::tryPlacingFurniture(
    const FurnishingRecord& record, const std::vector<float>& depths) {
  PlacedFurniture placed;
  const auto width = [&](int i) { return record.furniture[i].s1 - record.furniture[i].s0; };
  // Widest first, so the narrow pieces fill what the wide ones leave.
  std::vector<int> order(record.furniture.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return width(a) > width(b); });
  std::vector<Spot> spots(record.furniture.size(), Spot{-1, 0});
  for (const int i : order) {
    const int first = rng_.integer(0, 3);
    for (int j = 0; j < 4; ++j) {
      const int k = (first + j) % 4;
      const FurnishingRecord::Wall& w = record.walls[k];
      const std::vector<Interval> starts =
          freeStarts(w.start, w.end, width(i), taken(record, placed, k, depths[i]), kFurnitureGap);
      if (starts.empty()) continue;
      float s = drawFrom(starts, rng_);
      // Half the pieces pushed to an end of their free stretch, so the
      // stretches left stay long enough for the pieces still to come.
      if (rng_.chance(0.5)) {
        for (const Interval& free : starts)
          if (s >= free.lo && s <= free.hi) s = s - free.lo < free.hi - s ? free.lo : free.hi;
      }
      spots[i] = {k, s};
      placed[k].push_back({s, s + width(i), depths[i]});
      break;
    }
  }
  return spots;
}

std::vector<Interval> Rearrangement::taken(const FurnishingRecord& record,
                                           const PlacedFurniture& placed, int k,
                                           float reach) const {
  std::vector<Interval> result = record.walls[k].no_furniture;
  for (const Placed& p : placed[k]) result.push_back({p.s0, p.s1});
  // Wall k starts where the one before ends, and ends where the next starts.
  const int before = (k + 3) % 4, after = (k + 1) % 4;
  const float before_length = record.walls[before].length, length = record.walls[k].length;
  for (const Placed& p : placed[before])
    if (p.s1 > before_length - reach - kFurnitureGap) result.push_back({-1.0f, p.depth});
  for (const Placed& p : placed[after])
    if (p.s0 < reach + kFurnitureGap) result.push_back({length - p.depth, length + 1.0f});
  return result;
}

int Rearrangement::moveFurniture(FurnishingRecord& record, const std::vector<int>& order,
                                 int count) {
  int moved = 0;
  for (size_t n = 0; n < order.size() && moved < count; ++n) {
    FurnishingRecord::Piece& piece = record.furniture[order[n]];
    const float width = piece.s1 - piece.s0, depth = reach(piece);
    PlacedFurniture placed;  // everything but the piece itself
    for (const FurnishingRecord::Piece& other : record.furniture)
      if (&other != &piece) placed[other.wall].push_back({other.s0, other.s1, reach(other)});
    const int first = rng_.integer(0, 3);
    for (int j = 0; j < 4; ++j) {
      const int k = (first + j) % 4;
      std::vector<Interval> keep_off = taken(record, placed, k, depth);
      // Decorations hang clear of the furniture below them (furnitureClearance).
      for (const FurnishingRecord::Piece& d : record.decorations)
        if (d.wall == k && d.z0 < furnitureClearance(0, 0, piece.z1).z1)
          keep_off.push_back({d.s0 - 0.05f, d.s1 + 0.05f});
      const FurnishingRecord::Wall& w = record.walls[k];
      std::vector<Interval> starts = freeStarts(w.start, w.end, width, keep_off, kFurnitureGap);
      // A move the eye cannot miss, not a nudge.
      if (k == piece.wall)
        cut(starts, piece.s0 - kLeastFurnitureMove, piece.s0 + kLeastFurnitureMove);
      if (starts.empty()) continue;
      movePiece(piece, k, drawFrom(starts, rng_), 0);
      ++moved;
      break;
    }
  }
  return moved;
}

float Rearrangement::reach(const FurnishingRecord::Piece& piece) const {
  const Wall w = b_.wall(piece.wall);
  float depth = 0;
  for (int b = piece.box_begin; b < piece.box_end; ++b) {
    Vec3f lo, hi;
    room_.boxes[b].worldBounds(lo, hi);
    for (const float x : {lo.x(), hi.x()})
      for (const float y : {lo.y(), hi.y()})
        depth = std::max(depth, (Eigen::Vector2f(x, y) - w.corner).dot(w.normal));
  }
  return depth;
}

void Rearrangement::rearrangeDecorations(FurnishingRecord& record,
                                         std::array<std::vector<Rect>, 4>& blocked) {
  std::vector<int> order(record.decorations.size());
  std::iota(order.begin(), order.end(), 0);
  for (int i = static_cast<int>(order.size()) - 1; i > 0; --i)
    std::swap(order[i], order[rng_.integer(0, i)]);
  for (const int i : order) {
    FurnishingRecord::Piece& piece = record.decorations[i];
    const float w = piece.s1 - piece.s0, h = piece.z1 - piece.z0;
    const float from_z = (piece.z0 + piece.z1) / 2;
    const auto fits = [&](int k, float sc, float zc) {
      const FurnishingRecord::Wall& wall_record = record.walls[k];
      return decorationFits(room_.hi.z(), sc, zc, w, h, wall_record.start, wall_record.end,
                            blocked[k]);
    };
    // A random spot, or else the first free one in a sweep over every wall, or
    // else (walls full) where it was.
    int to_wall = -1;
    float to_sc = 0, to_z = 0;
    for (int attempt = 0; attempt < kDecorationAttempts && to_wall < 0; ++attempt) {
      const int k = rng_.integer(0, 3);
      const auto [sc, zc] = drawDecorationSpot(rng_, room_.hi.z(), w, h, record.walls[k].length);
      if (fits(k, sc, zc)) std::tie(to_wall, to_sc, to_z) = std::tuple(k, sc, zc);
    }
    for (int k = 0; k < 4 && to_wall < 0; ++k)
      for (float sc = w / 2; sc < record.walls[k].length - w / 2 && to_wall < 0; sc += 0.05f)
        for (float zc = 0.9f + h / 2; zc < room_.hi.z() - h / 2 && to_wall < 0; zc += 0.05f)
          if (fits(k, sc, zc)) std::tie(to_wall, to_sc, to_z) = std::tuple(k, sc, zc);
    if (to_wall < 0)
      std::tie(to_wall, to_sc, to_z) = std::tuple(piece.wall, (piece.s0 + piece.s1) / 2, from_z);
    movePiece(piece, to_wall, to_sc - w / 2, to_z - from_z);
    blocked[to_wall].push_back({to_sc - w / 2, to_sc + w / 2, to_z - h / 2, to_z + h / 2});
  }
}

void Rearrangement::movePiece(FurnishingRecord::Piece& piece, int to, float to_s, float dz) {
  const int from = piece.wall;
  const float from_s = piece.s0;
  const Wall a = b_.wall(from), b = b_.wall(to);
  // The turn from wall a's (tangent, normal) to wall b's is a multiple of 90
  // degrees: its cosine and sine are exactly 0 or +-1, so a box turned with it
  // keeps its size, faces and texture coordinates to the bit.
  const float c = a.tangent.x() * b.tangent.x() + a.normal.x() * b.normal.x();
  const float s = a.tangent.x() * b.tangent.y() + a.normal.x() * b.normal.y();
  for (int i = piece.box_begin; i < piece.box_end; ++i) {
    Box& box = room_.boxes[i];
    const Eigen::Vector2f p = box.centre.head<2>() - a.corner;
    const Eigen::Vector2f q =
        b.corner + (p.dot(a.tangent) - from_s + to_s) * b.tangent + p.dot(a.normal) * b.normal;
    box.centre = Vec3f(q.x(), q.y(), box.centre.z() + dz);
    if (from == to) continue;
    if (box.rotated) {
      const float cos_yaw = box.cos_yaw, sin_yaw = box.sin_yaw;
      box.cos_yaw = c * cos_yaw - s * sin_yaw;
      box.sin_yaw = s * cos_yaw + c * sin_yaw;
    } else {
      box.rotated = true;
      box.cos_yaw = c;
      box.sin_yaw = s;
    }
  }
  piece.wall = to;
  piece.s1 = to_s + (piece.s1 - piece.s0);
  piece.s0 = to_s;
  piece.z0 += dz;
  piece.z1 += dz;
}

}  // namespace synthetic
}  // namespace relocalizer
