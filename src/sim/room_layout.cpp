// The room's layout: dimensions, wall finishes, furniture along the walls,
// decorations, lights, and the BVH over all boxes. Everything follows from the
// seed through synthetic::Rng, in a fixed order, so a seed always gives the
// same room.

#include <numeric>

#include "synthetic_internal.h"

namespace relocalizer {
namespace synthetic {
namespace {

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

// Binary BVH node, only used while building.
struct BvhNode {
  Vec3f lo = Vec3f::Zero(), hi = Vec3f::Zero();
  int first = 0;  // leaf: first box; inner: left child (right child is first + 1)
  int count = 0;  // boxes in a leaf; 0 for inner nodes
};

// Builds the room's furniture in wall coordinates: s along the wall from its
// left corner (seen from inside), w out from the wall into the room, z up.
class RoomBuilder {
 public:
  RoomBuilder(SyntheticRoom::Impl& room, Rng& rng) : room_(room), rng_(rng) {}

  int material(Material m) {
    m.seed = rng_.seed32();
    room_.materials.push_back(m);
    return static_cast<int>(room_.materials.size()) - 1;
  }
  int plain(const Vec3f& colour) {
    Material m;
    m.pattern = Pattern::kPlain;
    m.a = colour;
    return material(m);
  }
  int wood(int palette = -1) {
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
  int painted() {
    const float v = rng_.uniform(0.25, 0.92);
    return plain(hsv(rng_.uniform(0, 1), rng_.uniform(0.05, 0.45), v));
  }
  Vec3f saturated() {
    return hsv(rng_.uniform(0, 1), rng_.uniform(0.45, 0.95), rng_.uniform(0.35, 0.95));
  }

  int addBox(const Vec3f& lo, const Vec3f& hi, const std::array<int, 6>& faces) {
    Box box;
    box.centre = (lo + hi) * 0.5f;
    box.half = (hi - lo).cwiseAbs() * 0.5f;
    box.material = faces;
    box.id = static_cast<int>(room_.boxes.size());
    room_.boxes.push_back(box);
    return box.id;
  }

  // --- wall frames
  struct Wall {
    Eigen::Vector2f corner, tangent, normal;
    float length;
  };
  Wall wall(int k) const {
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
  Vec3f wallPoint(int k, float s, float w, float z) const {
    const Wall f = wall(k);
    const Eigen::Vector2f p = f.corner + s * f.tangent + w * f.normal;
    return {p.x(), p.y(), z};
  }
  int frontFace(int k) const {
    const Wall f = wall(k);
    return std::abs(f.normal.x()) > 0.5f ? faceIndex(0, f.normal.x() > 0)
                                         : faceIndex(1, f.normal.y() > 0);
  }
  // An axis-aligned box given in wall coordinates; `front` (if >= 0) is the
  // material of the face looking into the room, `top` that of the upper face.
  int wallBox(int k, float s0, float s1, float w0, float w1, float z0, float z1, int m,
              int front = -1, int top = -1) {
    auto faces = allFaces(m);
    if (front >= 0) faces[frontFace(k)] = front;
    if (top >= 0) faces[faceIndex(2, true)] = top;
    return addBox(wallPoint(k, s0, w0, z0).cwiseMin(wallPoint(k, s1, w1, z1)),
                  wallPoint(k, s0, w0, z0).cwiseMax(wallPoint(k, s1, w1, z1)), faces);
  }
  // A box turned by `yaw` (radians) about its vertical axis, given by its
  // centre in wall coordinates and its half sizes along (s, w, z).
  void turnedBox(int k, float s, float w, float z, const Vec3f& half, float yaw,
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

  // --- materials of several kinds
  int spine() {
    Material m;
    m.pattern = Pattern::kSpine;
    m.a = hsv(rng_.uniform(0, 1), rng_.uniform(0.3, 0.9), rng_.uniform(0.2, 0.9));
    m.b = rng_.chance(0.5) ? Vec3f(0.85f, 0.75f, 0.35f) : saturated();
    m.c = rng_.chance(0.5) ? Vec3f(0.95f, 0.93f, 0.88f) : Vec3f(0.08f, 0.08f, 0.08f);
    m.variant = rng_.integer(0, 3);
    return material(m);
  }
  int poster(float width, float height, bool cork) {
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
  int painting() {
    Material m;
    m.pattern = Pattern::kPainting;
    const float h = rng_.uniform(0, 1);
    m.a = hsv(h, rng_.uniform(0.3, 0.9), rng_.uniform(0.2, 0.6));
    m.b = hsv(h + rng_.uniform(0.2, 0.5), rng_.uniform(0.3, 0.9), rng_.uniform(0.5, 0.95));
    m.c = hsv(h + rng_.uniform(0.5, 0.8), rng_.uniform(0.2, 0.8), rng_.uniform(0.6, 1.0));
    m.variant = rng_.integer(0, 1);
    return material(m);
  }

  // ------------------------------------------------------------ furniture
  // Each returns the height of what it put against the wall, so decorations
  // keep clear of it.

  float bookshelf(int k, float s0, float width) {
    const float depth = rng_.uniform(0.30, 0.36), height = rng_.uniform(1.7, 2.0);
    const float th = 0.02f, s1 = s0 + width;
    const int body = wood(), back = rng_.chance(0.5) ? wood() : painted();
    wallBox(k, s0, s0 + th, 0, depth, 0, height, body);
    wallBox(k, s1 - th, s1, 0, depth, 0, height, body);
    wallBox(k, s0, s1, 0, depth, height - th, height, body);
    wallBox(k, s0 + th, s1 - th, 0, depth - 0.02f, 0, 0.08f, body);
    wallBox(k, s0 + th, s1 - th, 0, 0.012f, 0.08f, height - th, back);
    const int shelves = rng_.integer(4, 5);
    const float pitch = (height - th - 0.08f) / shelves;
    const int pages = plain({0.93f, 0.9f, 0.8f});
    for (int i = 0; i < shelves; ++i) {
      const float z0 = 0.08f + i * pitch;
      if (i > 0) wallBox(k, s0 + th, s1 - th, 0.012f, depth, z0 - th, z0, body);
      if (rng_.chance(0.15)) {  // a storage box instead of books
        const float bw = std::min(width - 2 * th - 0.04f, rng_.uniform(0.25, 0.45));
        const float start = s0 + th + rng_.uniform(0.01, width - 2 * th - bw - 0.01);
        wallBox(k, start, start + bw, 0.03f, depth - 0.01f, z0, z0 + pitch * 0.7f, painted());
        continue;
      }
      float s = s0 + th + 0.003f;
      const float front = depth - rng_.uniform(0.01, 0.03);
      while (true) {
        if (rng_.chance(0.05)) {
          s += rng_.uniform(0.04, 0.12);
          continue;
        }
        const float bw = rng_.uniform(0.018, 0.055);
        if (s + bw > s1 - th - 0.003f) break;
        const float bh = (pitch - th) * rng_.uniform(0.6, 0.93);
        const float bd = std::min(rng_.uniform(0.15, 0.24), front - 0.02f);
        const int cover = spine();
        wallBox(k, s, s + bw, front - bd, front, z0, z0 + bh, cover, cover, pages);
        s += bw + (rng_.chance(0.3) ? 0.002f : 0.0f);
      }
    }
    return height;
  }

  void bookStack(int k, float s, float w, float z, int count) {
    const int pages = plain({0.93f, 0.9f, 0.8f});
    for (int i = 0; i < count; ++i) {
      const float len = rng_.uniform(0.18, 0.28), dep = rng_.uniform(0.14, 0.2);
      const float th = rng_.uniform(0.025, 0.05);
      const float ds = rng_.uniform(-0.02, 0.02);
      const int cover = spine();
      wallBox(k, s + ds, s + ds + len, w, w + dep, z, z + th, cover, cover, pages);
      z += th;
    }
  }

  float desk(int k, float s0, float width) {
    const float depth = rng_.uniform(0.55, 0.65), height = rng_.uniform(0.72, 0.76);
    const float s1 = s0 + width;
    const int top = rng_.chance(0.6) ? wood() : ([&] {
      Material m;
      m.pattern = Pattern::kSpeckle;
      m.a = Vec3f(0.86f, 0.86f, 0.84f);
      m.b = Vec3f(0.6f, 0.6f, 0.62f);
      m.c = Vec3f(0.3f, 0.3f, 0.3f);
      return material(m);
    })();
    const int legs = rng_.chance(0.5) ? plain({0.22f, 0.22f, 0.24f}) : top;
    wallBox(k, s0, s1, 0, depth, height - 0.03f, height, top);
    const float l = 0.05f;
    for (const float s : {s0 + 0.03f, s1 - 0.03f - l})
      for (const float w : {0.03f, depth - 0.03f - l})
        wallBox(k, s, s + l, w, w + l, 0, height - 0.03f, legs);
    // A drawer unit under one end gives the underside some edges too.
    if (rng_.chance(0.6)) {
      const float dw = 0.4f;
      const float ds = rng_.chance(0.5) ? s0 + 0.1f : s1 - 0.1f - dw;
      const int body = painted();
      wallBox(k, ds, ds + dw, 0.05f, depth - 0.05f, height - 0.45f, height - 0.03f, body);
      const int handle = plain({0.7f, 0.7f, 0.72f});
      for (int i = 0; i < 2; ++i) {
        const float z0 = height - 0.45f + 0.01f + i * 0.205f;
        wallBox(k, ds + 0.01f, ds + dw - 0.01f, depth - 0.05f, depth - 0.035f, z0, z0 + 0.195f,
                body);
        wallBox(k, ds + dw / 2 - 0.06f, ds + dw / 2 + 0.06f, depth - 0.035f, depth - 0.015f,
                z0 + 0.14f, z0 + 0.16f, handle);
      }
    }
    float top_height = height;
    float free_s = s0 + 0.05f;
    if (width >= 1.0f && rng_.chance(0.75)) {  // a monitor
      const float mw = rng_.uniform(0.48, 0.62), mh = mw * 0.6f;
      const float ms = s0 + rng_.uniform(0.3, 0.6) * (width - mw);
      const float mwall = rng_.uniform(0.12, 0.2);
      const int body = plain({0.16f, 0.16f, 0.17f});
      Material screen;
      screen.pattern = Pattern::kScreen;
      screen.a = Vec3f(0.025f, 0.025f, 0.03f);
      const int screen_m = material(screen);
      wallBox(k, ms + mw / 2 - 0.12f, ms + mw / 2 + 0.12f, mwall - 0.04f, mwall + 0.14f, height,
              height + 0.015f, body);
      wallBox(k, ms + mw / 2 - 0.025f, ms + mw / 2 + 0.025f, mwall - 0.02f, mwall, height,
              height + 0.2f, body);
      wallBox(k, ms, ms + mw, mwall, mwall + 0.035f, height + 0.1f, height + 0.1f + mh, body);
      wallBox(k, ms + 0.015f, ms + mw - 0.015f, mwall + 0.035f, mwall + 0.04f, height + 0.115f,
              height + 0.085f + mh, screen_m);
      top_height = height + 0.1f + mh;
      free_s = ms + mw + 0.05f;
    }
    if (s1 - free_s > 0.35f && rng_.chance(0.8)) {
      bookStack(k, free_s + rng_.uniform(0.0, 0.05), rng_.uniform(0.05, 0.2), height,
                rng_.integer(2, 4));
      free_s += 0.35f;
    }
    if (s1 - free_s > 0.2f) {  // a mug or a box, turned at random
      const float half = rng_.uniform(0.04, 0.09);
      turnedBox(k, free_s + 0.1f, depth * rng_.uniform(0.4, 0.7), height + half,
                Vec3f(half, half * rng_.uniform(0.8, 1.6), half), rng_.uniform(0, 1.5),
                allFaces(rng_.chance(0.5) ? painted() : poster(2 * half, 2 * half, false)));
    }
    // A chair pushed in, turned a little.
    if (rng_.chance(0.6)) {
      const float cs = s0 + width * rng_.uniform(0.3, 0.7);
      const float cw = depth - rng_.uniform(0.05, 0.15);
      const float yaw = rng_.uniform(-0.3, 0.3);
      const int seat = rng_.chance(0.5) ? painted() : wood();
      const float c = std::cos(yaw), sn = std::sin(yaw);
      auto part = [&](float ls, float lw, float z, const Vec3f& half) {
        turnedBox(k, cs + c * ls - sn * lw, cw + sn * ls + c * lw, z, half, yaw, allFaces(seat));
      };
      part(0, 0, 0.45f, {0.22f, 0.22f, 0.025f});
      part(0, 0.2f, 0.7f, {0.22f, 0.02f, 0.2f});
      for (const float ls : {-0.19f, 0.19f})
        for (const float lw : {-0.19f, 0.19f}) part(ls, lw, 0.21f, {0.02f, 0.02f, 0.21f});
    }
    return top_height;
  }

  float cabinet(int k, float s0, float width) {
    const float depth = rng_.uniform(0.4, 0.5), height = rng_.uniform(0.75, 0.95);
    const float s1 = s0 + width;
    const int body = rng_.chance(0.5) ? wood() : painted();
    const int fronts = rng_.chance(0.5) ? body : (rng_.chance(0.5) ? wood() : painted());
    const int handle =
        plain(rng_.chance(0.5) ? Vec3f(0.72f, 0.72f, 0.74f) : Vec3f(0.12f, 0.12f, 0.12f));
    wallBox(k, s0, s1, 0, depth, 0.08f, height - 0.03f, body);
    wallBox(k, s0 + 0.03f, s1 - 0.03f, 0, depth - 0.04f, 0, 0.08f, plain({0.1f, 0.1f, 0.1f}));
    int top = body;
    if (rng_.chance(0.4)) {
      Material m;
      m.pattern = Pattern::kSpeckle;
      m.a = Vec3f(0.35f, 0.35f, 0.37f);
      m.b = Vec3f(0.75f, 0.72f, 0.68f);
      m.c = Vec3f(0.08f, 0.08f, 0.08f);
      top = material(m);
    }
    wallBox(k, s0 - 0.02f, s1 + 0.02f, 0, depth + 0.02f, height - 0.03f, height, top);
    const int cols = std::max(1, static_cast<int>(std::lround(width / 0.45f)));
    const int rows = rng_.integer(1, 3);
    const float cw = width / cols, rh = (height - 0.11f) / rows;
    for (int i = 0; i < cols; ++i)
      for (int j = 0; j < rows; ++j) {
        const float fs = s0 + i * cw, fz = 0.08f + j * rh;
        wallBox(k, fs + 0.008f, fs + cw - 0.008f, depth, depth + 0.018f, fz + 0.008f,
                fz + rh - 0.008f, fronts);
        const bool drawer = rows > 1;
        const float hs = drawer ? fs + cw / 2 : (i % 2 == 0 ? fs + cw - 0.06f : fs + 0.06f);
        const float hz = drawer ? fz + rh * 0.75f : fz + rh * 0.7f;
        const Vec3f size = drawer ? Vec3f(0.07f, 0, 0.01f) : Vec3f(0.01f, 0, 0.06f);
        wallBox(k, hs - size.x(), hs + size.x(), depth + 0.018f, depth + 0.04f, hz - size.z(),
                hz + size.z(), handle);
      }
    float top_height = height;
    if (width >= 1.2f && rng_.chance(0.5)) {  // a television
      const float tw = std::min(width - 0.2f, rng_.uniform(0.8, 1.1)), th = tw * 0.58f;
      const float ts = s0 + (width - tw) / 2;
      const int frame = plain({0.1f, 0.1f, 0.11f});
      Material screen;
      screen.pattern = Pattern::kScreen;
      screen.a = Vec3f(0.02f, 0.02f, 0.025f);
      wallBox(k, ts + tw / 2 - 0.15f, ts + tw / 2 + 0.15f, 0.1f, 0.3f, height, height + 0.02f,
              frame);
      wallBox(k, ts, ts + tw, 0.15f, 0.2f, height + 0.06f, height + 0.06f + th, frame);
      wallBox(k, ts + 0.02f, ts + tw - 0.02f, 0.2f, 0.205f, height + 0.08f, height + 0.04f + th,
              material(screen));
      return height + 0.06f + th;
    }
    // A few objects on top: a vase, a plant, a framed photo.
    float s = s0 + rng_.uniform(0.05, 0.2);
    while (s < s1 - 0.2f) {
      const int kind = rng_.integer(0, 3);
      if (kind == 0) {
        const float r = rng_.uniform(0.05, 0.08), h = rng_.uniform(0.15, 0.35);
        turnedBox(k, s + r, depth * 0.5f, height + h / 2, {r, r, h / 2}, rng_.uniform(0, 1.5),
                  allFaces(painted()));
        top_height = std::max(top_height, height + h);
        s += 2 * r + rng_.uniform(0.1, 0.3);
      } else if (kind == 1) {
        Material pot;
        pot.pattern = Pattern::kSpeckle;
        pot.a = Vec3f(0.66f, 0.36f, 0.24f);
        pot.b = Vec3f(0.5f, 0.26f, 0.18f);
        pot.c = Vec3f(0.75f, 0.5f, 0.35f);
        wallBox(k, s, s + 0.14f, depth * 0.5f - 0.07f, depth * 0.5f + 0.07f, height, height + 0.13f,
                material(pot));
        turnedBox(k, s + 0.07f, depth * 0.5f, height + 0.25f, {0.12f, 0.12f, 0.12f},
                  rng_.uniform(0, 1.5), allFaces(foliage()));
        top_height = std::max(top_height, height + 0.37f);
        s += 0.3f + rng_.uniform(0.05, 0.25);
      } else if (kind == 2) {
        const float fw = rng_.uniform(0.12, 0.22), fh = fw * rng_.uniform(1.1, 1.4);
        const int frame = rng_.chance(0.5) ? wood() : plain({0.1f, 0.1f, 0.1f});
        const float w = depth * 0.3f;
        wallBox(k, s, s + fw, w, w + 0.02f, height, height + fh, frame, frame);
        wallBox(k, s + 0.015f, s + fw - 0.015f, w + 0.02f, w + 0.024f, height + 0.015f,
                height + fh - 0.015f, painting());
        top_height = std::max(top_height, height + fh);
        s += fw + rng_.uniform(0.1, 0.3);
      } else {
        bookStack(k, s, rng_.uniform(0.1, 0.2), height, rng_.integer(1, 3));
        s += 0.35f;
      }
    }
    return top_height;
  }

  float wardrobe(int k, float s0, float width) {
    const float depth = 0.55f, height = rng_.uniform(1.9, 2.1), s1 = s0 + width;
    const int body = rng_.chance(0.6) ? wood() : painted();
    const int handle = plain({0.7f, 0.7f, 0.72f});
    wallBox(k, s0, s1, 0, depth, 0, height, body);
    const float half = width / 2;
    for (int i = 0; i < 2; ++i) {
      const float fs = s0 + i * half;
      wallBox(k, fs + 0.005f, fs + half - 0.005f, depth, depth + 0.02f, 0.08f, height - 0.04f,
              body);
      // Raised panels on the door.
      for (int j = 0; j < 2; ++j) {
        const float z0 = j == 0 ? 0.2f : height * 0.5f + 0.05f;
        const float z1 = j == 0 ? height * 0.5f - 0.05f : height - 0.16f;
        wallBox(k, fs + 0.08f, fs + half - 0.08f, depth + 0.02f, depth + 0.03f, z0, z1, body);
      }
      const float hs = i == 0 ? fs + half - 0.05f : fs + 0.05f;
      wallBox(k, hs - 0.01f, hs + 0.01f, depth + 0.02f, depth + 0.05f, 0.95f, 1.2f, handle);
    }
    return height;
  }

  int foliage() {
    Material m;
    m.pattern = Pattern::kFoliage;
    m.a = Vec3f(0.08f, 0.25f, 0.07f);
    m.b = Vec3f(0.35f, 0.6f, 0.2f);
    return material(m);
  }

  // ------------------------------------------------------------ wall features

  void door(int k, float s0, float width, float height) {
    const float s1 = s0 + width;
    const Vec3f paint = hsv(rng_.uniform(0, 1), rng_.uniform(0, 0.3), rng_.uniform(0.5, 0.95));
    const bool wooden = rng_.chance(0.5);
    const int leaf = wooden ? wood() : plain(paint);
    // Painted panels a shade darker, so their edges show as they would in shadow.
    const int panel = wooden ? leaf : plain(paint * 0.85f);
    const int trim = plain({0.93f, 0.92f, 0.88f});
    wallBox(k, s0, s1, 0, 0.012f, 0, height, leaf);
    const int rows = rng_.integer(2, 3);
    const float ph = (height - 0.25f) / rows;
    for (int c = 0; c < 2; ++c)
      for (int r = 0; r < rows; ++r) {
        const float ps = s0 + 0.1f + c * (width - 0.2f) / 2;
        const float pz = 0.15f + r * ph;
        wallBox(k, ps + 0.02f, ps + (width - 0.2f) / 2 - 0.02f, 0.012f, 0.02f, pz + 0.02f,
                pz + ph - 0.02f, panel);
      }
    wallBox(k, s0 - 0.07f, s0, 0, 0.022f, 0, height + 0.07f, trim);
    wallBox(k, s1, s1 + 0.07f, 0, 0.022f, 0, height + 0.07f, trim);
    wallBox(k, s0 - 0.07f, s1 + 0.07f, 0, 0.022f, height, height + 0.07f, trim);
    const int metal = plain({0.75f, 0.72f, 0.6f});
    wallBox(k, s1 - 0.09f, s1 - 0.05f, 0.012f, 0.025f, 0.95f, 1.1f, metal);
    wallBox(k, s1 - 0.16f, s1 - 0.05f, 0.025f, 0.075f, 1.03f, 1.05f, metal);
  }

  void window(int k, float s0, float width, float z0, float z1) {
    const float s1 = s0 + width, sc = (s0 + s1) / 2;
    Material sky;
    sky.pattern = Pattern::kSky;
    sky.gives_depth = false;
    wallBox(k, s0, s1, 0, 0.004f, z0, z1, material(sky));
    const int frame = rng_.chance(0.6) ? plain({0.95f, 0.95f, 0.94f}) : wood();
    const float f = 0.07f;
    wallBox(k, s0 - f, s0, 0, 0.06f, z0, z1, frame);
    wallBox(k, s1, s1 + f, 0, 0.06f, z0, z1, frame);
    wallBox(k, s0 - f, s1 + f, 0, 0.06f, z1, z1 + f, frame);
    wallBox(k, s0 - f - 0.04f, s1 + f + 0.04f, 0, 0.17f, z0 - 0.04f, z0, frame);
    wallBox(k, sc - 0.025f, sc + 0.025f, 0, 0.045f, z0, z1, frame);
    const float zt = z0 + (z1 - z0) * 0.68f;
    wallBox(k, s0, s1, 0, 0.045f, zt - 0.025f, zt + 0.025f, frame);
    // Curtains either side; their folds and print are good texture.
    Material curtain;
    curtain.pattern = Pattern::kCurtain;
    curtain.a = hsv(rng_.uniform(0, 1), rng_.uniform(0.2, 0.7), rng_.uniform(0.4, 0.85));
    curtain.b = saturated();
    curtain.variant = rng_.integer(0, 1);
    const int cm = material(curtain);
    const float cw = rng_.uniform(0.25, 0.4);
    wallBox(k, s0 - f - cw - 0.02f, s0 - f - 0.02f, 0.08f, 0.14f, 0.05f, z1 + 0.12f, cm);
    wallBox(k, s1 + f + 0.02f, s1 + f + cw + 0.02f, 0.08f, 0.14f, 0.05f, z1 + 0.12f, cm);
    wallBox(k, s0 - f - cw - 0.08f, s1 + f + cw + 0.08f, 0.1f, 0.13f, z1 + 0.12f, z1 + 0.15f,
            plain({0.2f, 0.18f, 0.16f}));
    // Radiator below.
    Material radiator;
    radiator.pattern = Pattern::kRadiator;
    radiator.a = Vec3f(0.93f, 0.93f, 0.92f);
    wallBox(k, s0 + 0.05f, s1 - 0.05f, 0.04f, 0.12f, 0.15f, std::min(0.7f, z0 - 0.12f),
            material(radiator));
  }

  void poster(int k, float sc, float zc, float w, float h) {
    wallBox(k, sc - w / 2, sc + w / 2, 0, 0.003f, zc - h / 2, zc + h / 2, poster(w, h, false));
  }

  void framedPicture(int k, float sc, float zc, float w, float h) {
    const int frame = rng_.integer(0, 2) == 0 ? plain({0.08f, 0.08f, 0.08f})
                      : rng_.chance(0.5)      ? plain({0.78f, 0.62f, 0.3f})
                                              : wood();
    const float fw = rng_.uniform(0.03, 0.07);
    wallBox(k, sc - w / 2, sc + w / 2, 0, 0.03f, zc - h / 2, zc + h / 2, frame);
    float inset = fw;
    if (rng_.chance(0.5)) {
      const float mat_w = rng_.uniform(0.03, 0.08);
      wallBox(k, sc - w / 2 + inset, sc + w / 2 - inset, 0.03f, 0.033f, zc - h / 2 + inset,
              zc + h / 2 - inset, plain({0.95f, 0.94f, 0.9f}));
      inset += mat_w;
    }
    wallBox(k, sc - w / 2 + inset, sc + w / 2 - inset, 0.03f, 0.036f, zc - h / 2 + inset,
            zc + h / 2 - inset, painting());
  }

  void corkboard(int k, float sc, float zc, float w, float h) {
    const int frame = wood();
    wallBox(k, sc - w / 2, sc + w / 2, 0, 0.02f, zc - h / 2, zc + h / 2, frame);
    wallBox(k, sc - w / 2 + 0.025f, sc + w / 2 - 0.025f, 0.02f, 0.023f, zc - h / 2 + 0.025f,
            zc + h / 2 - 0.025f, poster(w - 0.05f, h - 0.05f, true));
  }

  void wallShelf(int k, float sc, float zc, float w) {
    const int board = wood();
    const float z = zc - 0.15f;
    wallBox(k, sc - w / 2, sc + w / 2, 0, 0.22f, z - 0.025f, z, board);
    for (const float s : {sc - w / 2 + 0.08f, sc + w / 2 - 0.1f})
      wallBox(k, s, s + 0.02f, 0, 0.15f, z - 0.15f, z - 0.025f, plain({0.15f, 0.15f, 0.15f}));
    const int pages = plain({0.93f, 0.9f, 0.8f});
    float s = sc - w / 2 + 0.03f;
    while (s < sc + w / 2 - 0.08f) {
      if (rng_.chance(0.25)) {
        const float r = rng_.uniform(0.04, 0.07), h = rng_.uniform(0.08, 0.25);
        if (s + 2 * r > sc + w / 2 - 0.02f) break;
        turnedBox(k, s + r, 0.11f, z + h / 2, {r, r, h / 2}, rng_.uniform(0, 1.5),
                  allFaces(painted()));
        s += 2 * r + 0.03f;
      } else {
        const float bw = rng_.uniform(0.02, 0.05), bh = rng_.uniform(0.16, 0.26);
        if (s + bw > sc + w / 2 - 0.02f) break;
        const int cover = spine();
        wallBox(k, s, s + bw, 0.02f, rng_.uniform(0.15, 0.2), z, z + bh, cover, cover, pages);
        s += bw;
      }
    }
  }

  void plant(int k, float s, float w) {
    Material pot;
    pot.pattern = Pattern::kSpeckle;
    pot.a = Vec3f(0.62f, 0.33f, 0.22f);
    pot.b = Vec3f(0.45f, 0.24f, 0.16f);
    pot.c = Vec3f(0.75f, 0.5f, 0.35f);
    const float yaw = rng_.uniform(0, 1.5);
    turnedBox(k, s, w, 0.2f, {0.17f, 0.17f, 0.2f}, yaw, allFaces(material(pot)));
    const int leaves = foliage();
    turnedBox(k, s, w, 0.75f, {0.26f, 0.22f, 0.36f}, yaw + 0.4f, allFaces(leaves));
    turnedBox(k, s + 0.03f, w - 0.02f, 1.2f, {0.17f, 0.15f, 0.2f}, yaw + 1.1f, allFaces(leaves));
  }

  void floorLamp(int k, float s, float w) {
    const int metal = plain({0.15f, 0.15f, 0.15f});
    turnedBox(k, s, w, 0.015f, {0.15f, 0.15f, 0.015f}, 0.3f, allFaces(metal));
    turnedBox(k, s, w, 0.8f, {0.015f, 0.015f, 0.8f}, 0.3f, allFaces(metal));
    Material shade;
    shade.pattern = Pattern::kCurtain;
    shade.a = Vec3f(0.92f, 0.86f, 0.72f);
    shade.b = Vec3f(0.8f, 0.7f, 0.5f);
    turnedBox(k, s, w, 1.65f, {0.2f, 0.2f, 0.15f}, 0.3f, allFaces(material(shade)));
  }

 private:
  SyntheticRoom::Impl& room_;
  Rng& rng_;
};

struct Interval {
  float lo, hi;
  bool overlaps(float a, float b) const { return a < hi && b > lo; }
};
struct Rect {
  float s0, s1, z0, z1;
};

}  // namespace

void buildRoom(SyntheticRoom::Impl& room) {
  Rng rng(mix64(room.seed ^ 0x5eed0f5ce9e5ULL));
  RoomBuilder b(room, rng);
  room.lo = Vec3f::Zero();
  room.hi = Vec3f(rng.uniform(5.6, 6.4), rng.uniform(4.6, 5.4), rng.uniform(2.6, 3.0));
  const float height = room.hi.z();

  // --- shell: one plain, texture-poor wall; the others patterned.
  const int plain_wall = rng.integer(0, 3);
  bool have_brick = false;
  std::array<int, 4> wall_material{};
  for (int k = 0; k < 4; ++k) {
    Material m;
    if (k == plain_wall) {
      m.pattern = Pattern::kPlain;
      m.a = hsv(rng.uniform(0, 1), rng.uniform(0.03, 0.2), rng.uniform(0.8, 0.92));
    } else if (!have_brick && rng.chance(0.3)) {
      have_brick = true;
      m.pattern = Pattern::kBrick;
      m.a = Vec3f(0.62f, 0.32f, 0.24f);
      m.b = Vec3f(0.75f, 0.48f, 0.36f);
      m.c = Vec3f(0.82f, 0.8f, 0.76f);
    } else {
      m.pattern = Pattern::kWallpaper;
      m.variant = rng.integer(0, 2);
      const float h = rng.uniform(0, 1);
      m.a = hsv(h, rng.uniform(0.1, 0.4), rng.uniform(0.7, 0.92));
      m.b = hsv(h + rng.uniform(-0.1, 0.1), rng.uniform(0.3, 0.7), rng.uniform(0.45, 0.75));
      m.c = hsv(h + rng.uniform(0.3, 0.7), rng.uniform(0.3, 0.8), rng.uniform(0.3, 0.9));
      m.scale = rng.uniform(0.12, 0.3);
    }
    wall_material[k] = b.material(m);
  }
  Material floor;
  if (rng.chance(0.65)) {
    floor.pattern = Pattern::kPlanks;
    const int p = rng.integer(0, 2);
    const float tones[3][6] = {{0.72f, 0.55f, 0.36f, 0.55f, 0.38f, 0.22f},
                               {0.55f, 0.36f, 0.24f, 0.38f, 0.22f, 0.14f},
                               {0.82f, 0.72f, 0.58f, 0.66f, 0.55f, 0.42f}};
    floor.a = Vec3f(tones[p][0], tones[p][1], tones[p][2]);
    floor.b = Vec3f(tones[p][3], tones[p][4], tones[p][5]);
    floor.c = floor.b * 0.5f;
    floor.scale = rng.uniform(0.12, 0.2);
  } else {
    floor.pattern = Pattern::kTiles;
    floor.a = hsv(rng.uniform(0, 1), rng.uniform(0, 0.3), rng.uniform(0.7, 0.9));
    floor.b = hsv(rng.uniform(0, 1), rng.uniform(0, 0.4), rng.uniform(0.25, 0.5));
    floor.c = Vec3f(0.5f, 0.5f, 0.48f);
    floor.scale = rng.uniform(0.3, 0.5);
  }
  // Faces: 0 x-lo (wall 3), 1 x-hi (wall 1), 2 y-lo (wall 0), 3 y-hi (wall 2).
  room.shell_material = {wall_material[3], wall_material[1],  wall_material[0],
                         wall_material[2], b.material(floor), b.plain({0.94f, 0.94f, 0.92f})};

  // --- corner pieces, then a sequence of furniture along each wall.
  std::array<bool, 4> corner_used{};
  for (int c = 0; c < 4; ++c) corner_used[c] = rng.chance(0.5);
  const int door_wall = rng.integer(0, 3);
  const int window_wall = (door_wall + rng.integer(1, 3)) % 4;
  const float skirting_h = 0.08f;
  const int skirting = b.plain({0.95f, 0.95f, 0.93f});

  for (int k = 0; k < 4; ++k) {
    const float length = b.wall(k).length;
    // Corner k is at s = 0 of wall k and s = length of wall k - 1.
    const float start = corner_used[k] ? 0.75f : 0.08f;
    const float end = length - (corner_used[(k + 1) % 4] ? 0.75f : 0.08f);
    if (corner_used[k]) {
      if (rng.chance(0.6))
        b.plant(k, 0.38f, 0.38f);
      else
        b.floorLamp(k, 0.35f, 0.35f);
    }
    b.wallBox(k, 0, length, 0, 0.015f, 0, skirting_h, skirting);

    std::vector<Rect> blocked;
    std::vector<Interval> no_furniture;
    if (k == door_wall) {
      const float w = rng.uniform(0.82, 0.92);
      const float s0 = rng.uniform(start + 0.15, std::max(start + 0.15, end - w - 0.15));
      const float h = rng.uniform(2.0, 2.1);
      b.door(k, s0, w, h);
      blocked.push_back({s0 - 0.1f, s0 + w + 0.1f, 0, h + 0.1f});
      no_furniture.push_back({s0 - 0.12f, s0 + w + 0.12f});
    }
    if (k == window_wall) {
      const float w = rng.uniform(1.0, 1.6);
      const float s0 = (length - w) / 2 + rng.uniform(-0.5, 0.5) * (length - w - 2.2f) / 2;
      const float z0 = rng.uniform(0.85, 0.95),
                  z1 = std::min(height - 0.3f, rng.uniform(2.05, 2.2));
      b.window(k, s0, w, z0, z1);
      // Curtains reach ~0.55 m either side; the radiator keeps the floor below.
      blocked.push_back({s0 - 0.55f, s0 + w + 0.55f, 0, z1 + 0.2f});
      no_furniture.push_back({s0 - 0.6f, s0 + w + 0.6f});
    }

    // Fewer things on the plain wall, leaving bare texture-poor stretches on purpose.
    const int max_items = k == plain_wall ? 2 : 4;
    int items = 0;
    float s = start + rng.uniform(0.0, 0.3);
    while (items < max_items && s < end - 0.6f) {
      const int kind = rng.integer(0, 9);  // 0-2 bookshelf, 3-5 desk, 6-8 cabinet, 9 wardrobe
      float width = kind <= 2   ? rng.uniform(0.8, 1.2)
                    : kind <= 5 ? rng.uniform(1.0, 1.6)
                    : kind <= 8 ? rng.uniform(0.8, 1.5)
                                : rng.uniform(0.9, 1.2);
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
      if (kind <= 2)
        top = b.bookshelf(k, s, width);
      else if (kind <= 5)
        top = b.desk(k, s, width);
      else if (kind <= 8)
        top = b.cabinet(k, s, width);
      else
        top = b.wardrobe(k, s, width);
      blocked.push_back({s - 0.05f, s + width + 0.05f, 0, top + 0.12f});
      ++items;
      s += width + (rng.chance(0.3) ? rng.uniform(0.6, 1.0) : rng.uniform(0.05, 0.35));
    }

    // Decorations where the wall is free, mostly at eye height.
    const int max_decor = k == plain_wall ? 2 : static_cast<int>(length / 1.1f);
    int decor = 0;
    for (int attempt = 0; attempt < 80 && decor < max_decor; ++attempt) {
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
      const float sc = rng.uniform(0.15 + w / 2, length - 0.15 - w / 2);
      const float zc =
          rng.uniform(std::max(1.0f + h / 2, 1.35f), std::min(height - 0.25f - h / 2, 1.85f));
      if (!(zc - h / 2 >= 0.9f && zc + h / 2 <= height - 0.2f)) continue;
      const Rect r{sc - w / 2 - 0.08f, sc + w / 2 + 0.08f, zc - h / 2 - 0.08f, zc + h / 2 + 0.08f};
      bool free = r.s0 > start - 0.7f && r.s1 < end + 0.7f;
      for (const Rect& o : blocked)
        free = free && !(r.s0 < o.s1 && r.s1 > o.s0 && r.z0 < o.z1 && r.z1 > o.z0);
      if (!free) continue;
      if (kind <= 2)
        b.poster(k, sc, zc, w, h);
      else if (kind <= 6)
        b.framedPicture(k, sc, zc, w, h);
      else if (kind == 7)
        b.corkboard(k, sc, zc, w, h);
      else
        b.wallShelf(k, sc, zc, w);
      blocked.push_back({sc - w / 2, sc + w / 2, zc - h / 2, zc + h / 2});
      ++decor;
    }
  }

  // A rug under the camera paths, turned a little.
  {
    Material rug;
    rug.pattern = Pattern::kRug;
    const float h = rng.uniform(0, 1);
    rug.a = hsv(h, rng.uniform(0.4, 0.8), rng.uniform(0.4, 0.7));
    rug.b = hsv(h + 0.5f, rng.uniform(0.2, 0.6), rng.uniform(0.6, 0.9));
    rug.c = hsv(h + rng.uniform(0.2, 0.35), rng.uniform(0.5, 0.9), rng.uniform(0.2, 0.5));
    rug.scale = rng.uniform(0.25, 0.4);
    const int m = b.material(rug);
    Box box;
    box.centre = Vec3f(room.hi.x() / 2, room.hi.y() / 2, 0.005f);
    box.half = Vec3f(rng.uniform(1.0, 1.3), rng.uniform(0.7, 0.9), 0.005f);
    const float yaw = rng.uniform(-0.2, 0.2);
    box.cos_yaw = std::cos(yaw);
    box.sin_yaw = std::sin(yaw);
    box.rotated = true;
    box.material = allFaces(m);
    box.id = static_cast<int>(room.boxes.size());
    room.boxes.push_back(box);
  }

  // Two ceiling lights; their fittings are small bright boxes.
  const int fitting = b.plain({1.0f, 1.0f, 0.97f});
  const std::array<Eigen::Vector2f, 2> light_xy = {
      Eigen::Vector2f(room.hi.x() * rng.uniform(0.3, 0.4), room.hi.y() * rng.uniform(0.4, 0.6)),
      Eigen::Vector2f(room.hi.x() * rng.uniform(0.6, 0.7), room.hi.y() * rng.uniform(0.4, 0.6))};
  for (int i = 0; i < 2; ++i) {
    const Vec3f p(light_xy[i].x(), light_xy[i].y(), height - 0.2f);
    b.addBox(p - Vec3f(0.2f, 0.2f, -0.15f), p + Vec3f(0.2f, 0.2f, 0.2f), allFaces(fitting));
    room.lights[i].position = p;
    const float warm = rng.uniform(0.0, 0.08);
    room.lights[i].colour = Vec3f(0.62f + warm, 0.6f, 0.58f - warm);
  }
  room.ambient = Vec3f(0.44f, 0.44f, 0.46f);
  room.light_falloff = 0.08f;

  // Distractor materials and the phases of the time-varying effects.
  Material person;
  person.pattern = Pattern::kClothes;
  person.a = b.saturated();
  person.b = Vec3f(0.9f, 0.9f, 0.88f);
  person.c = Vec3f(0.15f, 0.2f, 0.35f);
  person.scale = 0.06f;
  room.person_material = b.material(person);
  Material cart = person;
  cart.variant = 1;
  cart.a = b.saturated();
  cart.b = Vec3f(0.1f, 0.1f, 0.1f);
  cart.scale = 0.1f;
  room.cart_material = b.material(cart);
  room.path_phase = rng.uniform(0, kTwoPi);
  for (double& p : room.phases) p = rng.uniform(0, kTwoPi);

  room.buildBvh();
}

}  // namespace synthetic

// ---------------------------------------------------------------- BVH

using namespace synthetic;

void SyntheticRoom::Impl::buildBvh() {
  const int n = static_cast<int>(boxes.size());
  std::vector<Vec3f> box_lo(n), box_hi(n), centroid(n);
  for (int i = 0; i < n; ++i) {
    boxes[i].worldBounds(box_lo[i], box_hi[i]);
    centroid[i] = (box_lo[i] + box_hi[i]) * 0.5f;
  }
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::vector<BvhNode> binary{BvhNode{}};
  binary.reserve(2 * static_cast<size_t>(n) + 1);
  auto area = [](const Vec3f& l, const Vec3f& h) {
    const Vec3f e = (h - l).cwiseMax(0.0f);
    return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
  };
  // Binned surface-area heuristic: the room is many small boxes (books)
  // beside a few big ones, where median splits make poor trees.
  constexpr int kBins = 16;
  constexpr float kTraversalCost = 1.0f, kBoxCost = 1.5f;
  struct Task {
    int node, begin, end;
  };
  std::vector<Task> tasks{{0, 0, n}};
  while (!tasks.empty()) {
    const Task task = tasks.back();
    tasks.pop_back();
    const int count = task.end - task.begin;
    Vec3f node_lo = Vec3f::Constant(kInf), node_hi = Vec3f::Constant(-kInf);
    Vec3f c_lo = node_lo, c_hi = node_hi;
    for (int i = task.begin; i < task.end; ++i) {
      node_lo = node_lo.cwiseMin(box_lo[order[i]]);
      node_hi = node_hi.cwiseMax(box_hi[order[i]]);
      c_lo = c_lo.cwiseMin(centroid[order[i]]);
      c_hi = c_hi.cwiseMax(centroid[order[i]]);
    }
    BvhNode& node = binary[task.node];
    node.lo = node_lo;
    node.hi = node_hi;
    node.first = task.begin;
    node.count = count;
    if (count <= 1) continue;
    float best_cost = kBoxCost * count;  // cost of staying a leaf, in units of the node's area
    int best_axis = -1, best_bin = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const float extent = c_hi[axis] - c_lo[axis];
      if (!(extent > 0.0f)) continue;
      std::array<int, kBins> bin_count{};
      std::array<Vec3f, kBins> bin_lo, bin_hi;
      bin_lo.fill(Vec3f::Constant(kInf));
      bin_hi.fill(Vec3f::Constant(-kInf));
      for (int i = task.begin; i < task.end; ++i) {
        const int b = std::min(
            kBins - 1, static_cast<int>(kBins * (centroid[order[i]][axis] - c_lo[axis]) / extent));
        ++bin_count[b];
        bin_lo[b] = bin_lo[b].cwiseMin(box_lo[order[i]]);
        bin_hi[b] = bin_hi[b].cwiseMax(box_hi[order[i]]);
      }
      std::array<float, kBins> right_area{};
      std::array<int, kBins> right_count{};
      Vec3f acc_lo = Vec3f::Constant(kInf), acc_hi = Vec3f::Constant(-kInf);
      int acc = 0;
      for (int b = kBins - 1; b > 0; --b) {
        acc_lo = acc_lo.cwiseMin(bin_lo[b]);
        acc_hi = acc_hi.cwiseMax(bin_hi[b]);
        acc += bin_count[b];
        right_area[b] = area(acc_lo, acc_hi);
        right_count[b] = acc;
      }
      acc_lo = Vec3f::Constant(kInf);
      acc_hi = Vec3f::Constant(-kInf);
      acc = 0;
      const float node_area = std::max(area(node_lo, node_hi), 1e-9f);
      for (int b = 0; b < kBins - 1; ++b) {
        acc_lo = acc_lo.cwiseMin(bin_lo[b]);
        acc_hi = acc_hi.cwiseMax(bin_hi[b]);
        acc += bin_count[b];
        if (acc == 0 || right_count[b + 1] == 0) continue;
        const float cost =
            kTraversalCost +
            kBoxCost * (acc * area(acc_lo, acc_hi) + right_count[b + 1] * right_area[b + 1]) /
                node_area;
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = axis;
          best_bin = b;
        }
      }
    }
    int mid;
    if (best_axis >= 0) {
      const int axis = best_axis;
      const float extent = c_hi[axis] - c_lo[axis];
      const auto split =
          std::partition(order.begin() + task.begin, order.begin() + task.end, [&](int i) {
            return std::min(kBins - 1, static_cast<int>(kBins * (centroid[i][axis] - c_lo[axis]) /
                                                        extent)) <= best_bin;
          });
      mid = static_cast<int>(split - order.begin());
    } else if (count > 4) {
      // Too many for one leaf even if SAH prefers it (coincident centroids).
      mid = (task.begin + task.end) / 2;
    } else {
      continue;
    }
    const int left = static_cast<int>(binary.size());
    binary.emplace_back();
    binary.emplace_back();
    binary[task.node].first = left;
    binary[task.node].count = 0;
    tasks.push_back({left + 1, mid, task.end});
    tasks.push_back({left, task.begin, mid});
  }
  std::vector<Box> sorted(n);
  for (int i = 0; i < n; ++i) sorted[i] = boxes[order[i]];
  boxes = std::move(sorted);

  // Collapse into four-wide nodes: open the largest inner children until four
  // slots are used.
  nodes.clear();
  if (n == 0) return;
  struct Collapse {
    const std::vector<BvhNode>& binary;
    std::vector<WideNode>& wide;
    float (*area)(const Vec3f&, const Vec3f&);
    int operator()(int b) {
      std::vector<int> slots;
      if (binary[b].count > 0)
        slots.push_back(b);  // a leaf root
      else
        slots = {binary[b].first, binary[b].first + 1};
      while (slots.size() < 4) {
        int open = -1;
        float best = -1.0f;
        for (int i = 0; i < static_cast<int>(slots.size()); ++i) {
          const BvhNode& c = binary[slots[i]];
          if (c.count == 0 && area(c.lo, c.hi) > best) {
            best = area(c.lo, c.hi);
            open = i;
          }
        }
        if (open < 0) break;
        const int opened = slots[open];
        slots[open] = binary[opened].first;
        slots.insert(slots.begin() + open + 1, binary[opened].first + 1);
      }
      const int index = static_cast<int>(wide.size());
      wide.emplace_back();
      for (int k = 0; k < 4; ++k) {
        const bool used = k < static_cast<int>(slots.size());
        const BvhNode* c = used ? &binary[slots[k]] : nullptr;
        for (int axis = 0; axis < 3; ++axis) {
          wide[index].lo[axis][k] = used ? c->lo[axis] : kInf;
          wide[index].hi[axis][k] = used ? c->hi[axis] : -kInf;
        }
        wide[index].count[k] = used ? c->count : -1;
        wide[index].child[k] = used && c->count > 0 ? c->first : 0;
      }
      for (int k = 0; k < static_cast<int>(slots.size()); ++k)
        if (binary[slots[k]].count == 0) {
          const int child = (*this)(slots[k]);
          wide[index].child[k] = child;
        }
      return index;
    }
  };
  Collapse collapse{binary, nodes, +area};
  collapse(0);
}

}  // namespace relocalizer
