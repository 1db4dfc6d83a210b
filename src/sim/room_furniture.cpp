// Furniture against a wall: bookshelves, desks, cabinets, wardrobes, and the
// things on them.

#include <algorithm>
#include <cmath>

#include "room_furniture.h"

namespace relocalizer {
namespace synthetic {

float Furniture::bookshelf(int k, float s0, float width) {
  const float depth = rng_.uniform(0.30, 0.36), height = rng_.uniform(1.7, 2.0);
  const float th = 0.02f, s1 = s0 + width;
  const int body = b_.wood(), back = rng_.chance(0.5) ? b_.wood() : b_.painted();
  b_.wallBox(k, s0, s0 + th, 0, depth, 0, height, body);
  b_.wallBox(k, s1 - th, s1, 0, depth, 0, height, body);
  b_.wallBox(k, s0, s1, 0, depth, height - th, height, body);
  b_.wallBox(k, s0 + th, s1 - th, 0, depth - 0.02f, 0, 0.08f, body);
  b_.wallBox(k, s0 + th, s1 - th, 0, 0.012f, 0.08f, height - th, back);
  const int shelves = rng_.integer(4, 5);
  const float pitch = (height - th - 0.08f) / shelves;
  const int pages = b_.plain({0.93f, 0.9f, 0.8f});
  for (int i = 0; i < shelves; ++i) {
    const float z0 = 0.08f + i * pitch;
    if (i > 0) b_.wallBox(k, s0 + th, s1 - th, 0.012f, depth, z0 - th, z0, body);
    if (rng_.chance(0.15)) {  // a storage box instead of books
      const float bw = std::min(width - 2 * th - 0.04f, rng_.uniform(0.25, 0.45));
      const float start = s0 + th + rng_.uniform(0.01, width - 2 * th - bw - 0.01);
      b_.wallBox(k, start, start + bw, 0.03f, depth - 0.01f, z0, z0 + pitch * 0.7f, b_.painted());
      continue;
    }
    shelfOfBooks(k, s0 + th, s1 - th, depth, z0, pitch, pages);
  }
  return height;
}

// Books standing on the shelf from `s0` to `s1` at height z0, with gaps now and then.
void Furniture::shelfOfBooks(int k, float s0, float s1, float depth, float z0, float pitch,
                             int pages) {
  const float th = 0.02f;
  float s = s0 + 0.003f;
  const float front = depth - rng_.uniform(0.01, 0.03);
  while (true) {
    if (rng_.chance(0.05)) {
      s += rng_.uniform(0.04, 0.12);
      continue;
    }
    const float bw = rng_.uniform(0.018, 0.055);
    if (s + bw > s1 - 0.003f) break;
    const float bh = (pitch - th) * rng_.uniform(0.6, 0.93);
    const float bd = std::min(rng_.uniform(0.15, 0.24), front - 0.02f);
    const int cover = b_.spine();
    b_.wallBox(k, s, s + bw, front - bd, front, z0, z0 + bh, cover, cover, pages);
    s += bw + (rng_.chance(0.3) ? 0.002f : 0.0f);
  }
}

void Furniture::bookStack(int k, float s, float w, float z, int count) {
  const int pages = b_.plain({0.93f, 0.9f, 0.8f});
  for (int i = 0; i < count; ++i) {
    const float len = rng_.uniform(0.18, 0.28), dep = rng_.uniform(0.14, 0.2);
    const float th = rng_.uniform(0.025, 0.05);
    const float ds = rng_.uniform(-0.02, 0.02);
    const int cover = b_.spine();
    b_.wallBox(k, s + ds, s + ds + len, w, w + dep, z, z + th, cover, cover, pages);
    z += th;
  }
}

float Furniture::desk(int k, float s0, float width) {
  const float depth = rng_.uniform(0.55, 0.65), height = rng_.uniform(0.72, 0.76);
  const float s1 = s0 + width;
  const int top = rng_.chance(0.6) ? b_.wood()
                                   : b_.speckle(Vec3f(0.86f, 0.86f, 0.84f),
                                                Vec3f(0.6f, 0.6f, 0.62f), Vec3f(0.3f, 0.3f, 0.3f));
  const int legs = rng_.chance(0.5) ? b_.plain({0.22f, 0.22f, 0.24f}) : top;
  b_.wallBox(k, s0, s1, 0, depth, height - 0.03f, height, top);
  const float l = 0.05f;
  for (const float s : {s0 + 0.03f, s1 - 0.03f - l})
    for (const float w : {0.03f, depth - 0.03f - l})
      b_.wallBox(k, s, s + l, w, w + l, 0, height - 0.03f, legs);
  // A drawer unit under one end gives the underside some edges too.
  if (rng_.chance(0.6)) deskDrawers(k, s0, s1, depth, height);
  float top_height = height;
  const float free_s = deskMonitor(k, s0, width, height, top_height);
  deskClutter(k, s1, depth, height, free_s);
  // A chair pushed in, turned a little.
  if (rng_.chance(0.6)) pushedInChair(k, s0, width, depth);
  return top_height;
}

void Furniture::deskDrawers(int k, float s0, float s1, float depth, float height) {
  const float dw = 0.4f;
  const float ds = rng_.chance(0.5) ? s0 + 0.1f : s1 - 0.1f - dw;
  const int body = b_.painted();
  b_.wallBox(k, ds, ds + dw, 0.05f, depth - 0.05f, height - 0.45f, height - 0.03f, body);
  const int handle = b_.plain({0.7f, 0.7f, 0.72f});
  for (int i = 0; i < 2; ++i) {
    const float z0 = height - 0.45f + 0.01f + i * 0.205f;
    b_.wallBox(k, ds + 0.01f, ds + dw - 0.01f, depth - 0.05f, depth - 0.035f, z0, z0 + 0.195f,
               body);
    b_.wallBox(k, ds + dw / 2 - 0.06f, ds + dw / 2 + 0.06f, depth - 0.035f, depth - 0.015f,
               z0 + 0.14f, z0 + 0.16f, handle);
  }
}

float Furniture::deskMonitor(int k, float s0, float width, float height, float& top_height) {
  if (!(width >= 1.0f && rng_.chance(0.75))) return s0 + 0.05f;
  const float mw = rng_.uniform(0.48, 0.62), mh = mw * 0.6f;
  const float ms = s0 + rng_.uniform(0.3, 0.6) * (width - mw);
  const float mwall = rng_.uniform(0.12, 0.2);
  const int body = b_.plain({0.16f, 0.16f, 0.17f});
  Material screen;
  screen.pattern = Pattern::kScreen;
  screen.a = Vec3f(0.025f, 0.025f, 0.03f);
  const int screen_m = b_.material(screen);
  b_.wallBox(k, ms + mw / 2 - 0.12f, ms + mw / 2 + 0.12f, mwall - 0.04f, mwall + 0.14f, height,
             height + 0.015f, body);
  b_.wallBox(k, ms + mw / 2 - 0.025f, ms + mw / 2 + 0.025f, mwall - 0.02f, mwall, height,
             height + 0.2f, body);
  b_.wallBox(k, ms, ms + mw, mwall, mwall + 0.035f, height + 0.1f, height + 0.1f + mh, body);
  b_.wallBox(k, ms + 0.015f, ms + mw - 0.015f, mwall + 0.035f, mwall + 0.04f, height + 0.115f,
             height + 0.085f + mh, screen_m);
  top_height = height + 0.1f + mh;
  return ms + mw + 0.05f;
}

// A book stack and a mug or box on the free desk top from `free_s`.
void Furniture::deskClutter(int k, float s1, float depth, float height, float free_s) {
  if (s1 - free_s > 0.35f && rng_.chance(0.8)) {
    const int begin = static_cast<int>(b_.room().boxes.size());
    bookStack(k, free_s + rng_.uniform(0.0, 0.05), rng_.uniform(0.05, 0.2), height,
              rng_.integer(2, 4));
    recordObject(begin);
    free_s += 0.35f;
  }
  if (s1 - free_s > 0.2f) {  // a mug or a box, turned at random
    const int begin = static_cast<int>(b_.room().boxes.size());
    const float half = rng_.uniform(0.04, 0.09);
    b_.turnedBox(
        k, free_s + 0.1f, depth * rng_.uniform(0.4, 0.7), height + half,
        Vec3f(half, half * rng_.uniform(0.8, 1.6), half), rng_.uniform(0, 1.5),
        allFaces(rng_.chance(0.5) ? b_.painted() : b_.posterMaterial(2 * half, 2 * half, false)));
    recordObject(begin);
  }
}

void Furniture::recordObject(int begin) {
  objects_.emplace_back(begin, static_cast<int>(b_.room().boxes.size()));
}

void Furniture::pushedInChair(int k, float s0, float width, float depth) {
  const float cs = s0 + width * rng_.uniform(0.3, 0.7);
  const float cw = depth - rng_.uniform(0.05, 0.15);
  const float yaw = rng_.uniform(-0.3, 0.3);
  const int seat = rng_.chance(0.5) ? b_.painted() : b_.wood();
  const float c = std::cos(yaw), sn = std::sin(yaw);
  auto part = [&](float ls, float lw, float z, const Vec3f& half) {
    b_.turnedBox(k, cs + c * ls - sn * lw, cw + sn * ls + c * lw, z, half, yaw, allFaces(seat));
  };
  part(0, 0, 0.45f, {0.22f, 0.22f, 0.025f});
  part(0, 0.2f, 0.7f, {0.22f, 0.02f, 0.2f});
  for (const float ls : {-0.19f, 0.19f})
    for (const float lw : {-0.19f, 0.19f}) part(ls, lw, 0.21f, {0.02f, 0.02f, 0.21f});
}

float Furniture::cabinet(int k, float s0, float width) {
  const float depth = rng_.uniform(0.4, 0.5), height = rng_.uniform(0.75, 0.95);
  const float s1 = s0 + width;
  const int body = rng_.chance(0.5) ? b_.wood() : b_.painted();
  const int fronts = rng_.chance(0.5) ? body : (rng_.chance(0.5) ? b_.wood() : b_.painted());
  const int handle =
      b_.plain(rng_.chance(0.5) ? Vec3f(0.72f, 0.72f, 0.74f) : Vec3f(0.12f, 0.12f, 0.12f));
  b_.wallBox(k, s0, s1, 0, depth, 0.08f, height - 0.03f, body);
  b_.wallBox(k, s0 + 0.03f, s1 - 0.03f, 0, depth - 0.04f, 0, 0.08f, b_.plain({0.1f, 0.1f, 0.1f}));
  int top = body;
  if (rng_.chance(0.4))
    top = b_.speckle(Vec3f(0.35f, 0.35f, 0.37f), Vec3f(0.75f, 0.72f, 0.68f),
                     Vec3f(0.08f, 0.08f, 0.08f));
  b_.wallBox(k, s0 - 0.02f, s1 + 0.02f, 0, depth + 0.02f, height - 0.03f, height, top);
  cabinetFronts(k, s0, width, depth, height, fronts, handle);
  if (width >= 1.2f && rng_.chance(0.5)) return television(k, s0, width, height);
  return cabinetTopObjects(k, s0, s1, depth, height);
}

// Doors (one row) or drawers (two or three rows) with their handles.
void Furniture::cabinetFronts(int k, float s0, float width, float depth, float height, int fronts,
                              int handle) {
  const int cols = std::max(1, static_cast<int>(std::lround(width / 0.45f)));
  const int rows = rng_.integer(1, 3);
  const float cw = width / cols, rh = (height - 0.11f) / rows;
  for (int i = 0; i < cols; ++i)
    for (int j = 0; j < rows; ++j) {
      const float fs = s0 + i * cw, fz = 0.08f + j * rh;
      b_.wallBox(k, fs + 0.008f, fs + cw - 0.008f, depth, depth + 0.018f, fz + 0.008f,
                 fz + rh - 0.008f, fronts);
      const bool drawer = rows > 1;
      const float hs = drawer ? fs + cw / 2 : (i % 2 == 0 ? fs + cw - 0.06f : fs + 0.06f);
      const float hz = drawer ? fz + rh * 0.75f : fz + rh * 0.7f;
      const Vec3f size = drawer ? Vec3f(0.07f, 0, 0.01f) : Vec3f(0.01f, 0, 0.06f);
      b_.wallBox(k, hs - size.x(), hs + size.x(), depth + 0.018f, depth + 0.04f, hz - size.z(),
                 hz + size.z(), handle);
    }
}

// A switched-off television standing on the cabinet; returns its top.
float Furniture::television(int k, float s0, float width, float height) {
  const float tw = std::min(width - 0.2f, rng_.uniform(0.8, 1.1)), th = tw * 0.58f;
  const float ts = s0 + (width - tw) / 2;
  const int frame = b_.plain({0.1f, 0.1f, 0.11f});
  Material screen;
  screen.pattern = Pattern::kScreen;
  screen.a = Vec3f(0.02f, 0.02f, 0.025f);
  b_.wallBox(k, ts + tw / 2 - 0.15f, ts + tw / 2 + 0.15f, 0.1f, 0.3f, height, height + 0.02f,
             frame);
  b_.wallBox(k, ts, ts + tw, 0.15f, 0.2f, height + 0.06f, height + 0.06f + th, frame);
  b_.wallBox(k, ts + 0.02f, ts + tw - 0.02f, 0.2f, 0.205f, height + 0.08f, height + 0.04f + th,
             b_.material(screen));
  return height + 0.06f + th;
}

// A few objects on top: a vase, a plant, a framed photo, books. Returns the
// highest top.
float Furniture::cabinetTopObjects(int k, float s0, float s1, float depth, float height) {
  float top_height = height;
  float s = s0 + rng_.uniform(0.05, 0.2);
  while (s < s1 - 0.2f) {
    const int begin = static_cast<int>(b_.room().boxes.size());
    const int kind = rng_.integer(0, 3);
    if (kind == 0) {
      const float r = rng_.uniform(0.05, 0.08), h = rng_.uniform(0.15, 0.35);
      b_.turnedBox(k, s + r, depth * 0.5f, height + h / 2, {r, r, h / 2}, rng_.uniform(0, 1.5),
                   allFaces(b_.painted()));
      top_height = std::max(top_height, height + h);
      s += 2 * r + rng_.uniform(0.1, 0.3);
    } else if (kind == 1) {
      b_.wallBox(k, s, s + 0.14f, depth * 0.5f - 0.07f, depth * 0.5f + 0.07f, height,
                 height + 0.13f,
                 b_.speckle(Vec3f(0.66f, 0.36f, 0.24f), Vec3f(0.5f, 0.26f, 0.18f),
                            Vec3f(0.75f, 0.5f, 0.35f)));
      b_.turnedBox(k, s + 0.07f, depth * 0.5f, height + 0.25f, {0.12f, 0.12f, 0.12f},
                   rng_.uniform(0, 1.5), allFaces(b_.foliage()));
      top_height = std::max(top_height, height + 0.37f);
      s += 0.3f + rng_.uniform(0.05, 0.25);
    } else if (kind == 2) {
      const float fw = rng_.uniform(0.12, 0.22), fh = fw * rng_.uniform(1.1, 1.4);
      const int frame = rng_.chance(0.5) ? b_.wood() : b_.plain({0.1f, 0.1f, 0.1f});
      const float w = depth * 0.3f;
      b_.wallBox(k, s, s + fw, w, w + 0.02f, height, height + fh, frame, frame);
      b_.wallBox(k, s + 0.015f, s + fw - 0.015f, w + 0.02f, w + 0.024f, height + 0.015f,
                 height + fh - 0.015f, b_.painting());
      top_height = std::max(top_height, height + fh);
      s += fw + rng_.uniform(0.1, 0.3);
    } else {
      bookStack(k, s, rng_.uniform(0.1, 0.2), height, rng_.integer(1, 3));
      s += 0.35f;
    }
    recordObject(begin);
  }
  return top_height;
}

float Furniture::wardrobe(int k, float s0, float width) {
  const float depth = 0.55f, height = rng_.uniform(1.9, 2.1), s1 = s0 + width;
  const int body = rng_.chance(0.6) ? b_.wood() : b_.painted();
  const int handle = b_.plain({0.7f, 0.7f, 0.72f});
  b_.wallBox(k, s0, s1, 0, depth, 0, height, body);
  const float half = width / 2;
  for (int i = 0; i < 2; ++i) {
    const float fs = s0 + i * half;
    b_.wallBox(k, fs + 0.005f, fs + half - 0.005f, depth, depth + 0.02f, 0.08f, height - 0.04f,
               body);
    // Raised panels on the door.
    for (int j = 0; j < 2; ++j) {
      const float z0 = j == 0 ? 0.2f : height * 0.5f + 0.05f;
      const float z1 = j == 0 ? height * 0.5f - 0.05f : height - 0.16f;
      b_.wallBox(k, fs + 0.08f, fs + half - 0.08f, depth + 0.02f, depth + 0.03f, z0, z1, body);
    }
    const float hs = i == 0 ? fs + half - 0.05f : fs + 0.05f;
    b_.wallBox(k, hs - 0.01f, hs + 0.01f, depth + 0.02f, depth + 0.05f, 0.95f, 1.2f, handle);
  }
  return height;
}

}  // namespace synthetic
}  // namespace relocalizer
