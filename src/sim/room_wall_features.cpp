// Features of a wall (a door, a window with curtains and a radiator,
// decorations) and small free-standing pieces (plants, a floor lamp).

#include <algorithm>
#include <cmath>

#include "room_wall_features.h"

namespace relocalizer {
namespace synthetic {

void WallFeatures::door(int k, float s0, float width, float height) {
  const float s1 = s0 + width;
  const Vec3f paint = hsv(rng_.uniform(0, 1), rng_.uniform(0, 0.3), rng_.uniform(0.5, 0.95));
  const bool wooden = rng_.chance(0.5);
  const int leaf = wooden ? b_.wood() : b_.plain(paint);
  // Painted panels a shade darker, so their edges show as they would in shadow.
  const int panel = wooden ? leaf : b_.plain(paint * 0.85f);
  const int trim = b_.plain({0.93f, 0.92f, 0.88f});
  b_.wallBox(k, s0, s1, 0, 0.012f, 0, height, leaf);
  const int rows = rng_.integer(2, 3);
  const float ph = (height - 0.25f) / rows;
  for (int c = 0; c < 2; ++c)
    for (int r = 0; r < rows; ++r) {
      const float ps = s0 + 0.1f + c * (width - 0.2f) / 2;
      const float pz = 0.15f + r * ph;
      b_.wallBox(k, ps + 0.02f, ps + (width - 0.2f) / 2 - 0.02f, 0.012f, 0.02f, pz + 0.02f,
                 pz + ph - 0.02f, panel);
    }
  b_.wallBox(k, s0 - 0.07f, s0, 0, 0.022f, 0, height + 0.07f, trim);
  b_.wallBox(k, s1, s1 + 0.07f, 0, 0.022f, 0, height + 0.07f, trim);
  b_.wallBox(k, s0 - 0.07f, s1 + 0.07f, 0, 0.022f, height, height + 0.07f, trim);
  const int metal = b_.plain({0.75f, 0.72f, 0.6f});
  b_.wallBox(k, s1 - 0.09f, s1 - 0.05f, 0.012f, 0.025f, 0.95f, 1.1f, metal);
  b_.wallBox(k, s1 - 0.16f, s1 - 0.05f, 0.025f, 0.075f, 1.03f, 1.05f, metal);
}

void WallFeatures::window(int k, float s0, float width, float z0, float z1) {
  const float s1 = s0 + width, sc = (s0 + s1) / 2;
  Material sky;
  sky.pattern = Pattern::kSky;
  sky.gives_depth = false;
  b_.wallBox(k, s0, s1, 0, 0.004f, z0, z1, b_.material(sky));
  const int frame = rng_.chance(0.6) ? b_.plain({0.95f, 0.95f, 0.94f}) : b_.wood();
  const float f = 0.07f;
  b_.wallBox(k, s0 - f, s0, 0, 0.06f, z0, z1, frame);
  b_.wallBox(k, s1, s1 + f, 0, 0.06f, z0, z1, frame);
  b_.wallBox(k, s0 - f, s1 + f, 0, 0.06f, z1, z1 + f, frame);
  b_.wallBox(k, s0 - f - 0.04f, s1 + f + 0.04f, 0, 0.17f, z0 - 0.04f, z0, frame);
  b_.wallBox(k, sc - 0.025f, sc + 0.025f, 0, 0.045f, z0, z1, frame);
  const float zt = z0 + (z1 - z0) * 0.68f;
  b_.wallBox(k, s0, s1, 0, 0.045f, zt - 0.025f, zt + 0.025f, frame);
  curtains(k, s0, s1, f, z1);
  // Radiator below.
  Material radiator;
  radiator.pattern = Pattern::kRadiator;
  radiator.a = Vec3f(0.93f, 0.93f, 0.92f);
  b_.wallBox(k, s0 + 0.05f, s1 - 0.05f, 0.04f, 0.12f, 0.15f, std::min(0.7f, z0 - 0.12f),
             b_.material(radiator));
}

// Curtains either side of a window whose frame is `frame` wide, hanging from a
// rail above it; their folds and print are good texture.
void WallFeatures::curtains(int k, float s0, float s1, float frame, float z1) {
  const float f = frame;
  Material curtain;
  curtain.pattern = Pattern::kCurtain;
  curtain.a = hsv(rng_.uniform(0, 1), rng_.uniform(0.2, 0.7), rng_.uniform(0.4, 0.85));
  curtain.b = b_.saturated();
  curtain.variant = rng_.integer(0, 1);
  const int cm = b_.material(curtain);
  const float cw = rng_.uniform(0.25, 0.4);
  b_.wallBox(k, s0 - f - cw - 0.02f, s0 - f - 0.02f, 0.08f, 0.14f, 0.05f, z1 + 0.12f, cm);
  b_.wallBox(k, s1 + f + 0.02f, s1 + f + cw + 0.02f, 0.08f, 0.14f, 0.05f, z1 + 0.12f, cm);
  b_.wallBox(k, s0 - f - cw - 0.08f, s1 + f + cw + 0.08f, 0.1f, 0.13f, z1 + 0.12f, z1 + 0.15f,
             b_.plain({0.2f, 0.18f, 0.16f}));
}

void WallFeatures::poster(int k, float sc, float zc, float w, float h) {
  b_.wallBox(k, sc - w / 2, sc + w / 2, 0, 0.003f, zc - h / 2, zc + h / 2,
             b_.posterMaterial(w, h, false));
}

void WallFeatures::framedPicture(int k, float sc, float zc, float w, float h) {
  const int frame = rng_.integer(0, 2) == 0 ? b_.plain({0.08f, 0.08f, 0.08f})
                    : rng_.chance(0.5)      ? b_.plain({0.78f, 0.62f, 0.3f})
                                            : b_.wood();
  const float fw = rng_.uniform(0.03, 0.07);
  b_.wallBox(k, sc - w / 2, sc + w / 2, 0, 0.03f, zc - h / 2, zc + h / 2, frame);
  float inset = fw;
  if (rng_.chance(0.5)) {
    const float mat_w = rng_.uniform(0.03, 0.08);
    b_.wallBox(k, sc - w / 2 + inset, sc + w / 2 - inset, 0.03f, 0.033f, zc - h / 2 + inset,
               zc + h / 2 - inset, b_.plain({0.95f, 0.94f, 0.9f}));
    inset += mat_w;
  }
  b_.wallBox(k, sc - w / 2 + inset, sc + w / 2 - inset, 0.03f, 0.036f, zc - h / 2 + inset,
             zc + h / 2 - inset, b_.painting());
}

void WallFeatures::corkboard(int k, float sc, float zc, float w, float h) {
  const int frame = b_.wood();
  b_.wallBox(k, sc - w / 2, sc + w / 2, 0, 0.02f, zc - h / 2, zc + h / 2, frame);
  b_.wallBox(k, sc - w / 2 + 0.025f, sc + w / 2 - 0.025f, 0.02f, 0.023f, zc - h / 2 + 0.025f,
             zc + h / 2 - 0.025f, b_.posterMaterial(w - 0.05f, h - 0.05f, true));
}

void WallFeatures::wallShelf(int k, float sc, float zc, float w) {
  const int board = b_.wood();
  const float z = zc - 0.15f;
  b_.wallBox(k, sc - w / 2, sc + w / 2, 0, 0.22f, z - 0.025f, z, board);
  for (const float s : {sc - w / 2 + 0.08f, sc + w / 2 - 0.1f})
    b_.wallBox(k, s, s + 0.02f, 0, 0.15f, z - 0.15f, z - 0.025f, b_.plain({0.15f, 0.15f, 0.15f}));
  const int pages = b_.plain({0.93f, 0.9f, 0.8f});
  float s = sc - w / 2 + 0.03f;
  while (s < sc + w / 2 - 0.08f) {
    if (rng_.chance(0.25)) {
      const float r = rng_.uniform(0.04, 0.07), h = rng_.uniform(0.08, 0.25);
      if (s + 2 * r > sc + w / 2 - 0.02f) break;
      b_.turnedBox(k, s + r, 0.11f, z + h / 2, {r, r, h / 2}, rng_.uniform(0, 1.5),
                   allFaces(b_.painted()));
      s += 2 * r + 0.03f;
    } else {
      const float bw = rng_.uniform(0.02, 0.05), bh = rng_.uniform(0.16, 0.26);
      if (s + bw > sc + w / 2 - 0.02f) break;
      const int cover = b_.spine();
      b_.wallBox(k, s, s + bw, 0.02f, rng_.uniform(0.15, 0.2), z, z + bh, cover, cover, pages);
      s += bw;
    }
  }
}

void WallFeatures::plant(int k, float s, float w) {
  const float yaw = rng_.uniform(0, 1.5);
  b_.turnedBox(k, s, w, 0.2f, {0.17f, 0.17f, 0.2f}, yaw,
               allFaces(b_.speckle(Vec3f(0.62f, 0.33f, 0.22f), Vec3f(0.45f, 0.24f, 0.16f),
                                   Vec3f(0.75f, 0.5f, 0.35f))));
  const int leaves = b_.foliage();
  b_.turnedBox(k, s, w, 0.75f, {0.26f, 0.22f, 0.36f}, yaw + 0.4f, allFaces(leaves));
  b_.turnedBox(k, s + 0.03f, w - 0.02f, 1.2f, {0.17f, 0.15f, 0.2f}, yaw + 1.1f, allFaces(leaves));
}

void WallFeatures::floorLamp(int k, float s, float w) {
  const int metal = b_.plain({0.15f, 0.15f, 0.15f});
  b_.turnedBox(k, s, w, 0.015f, {0.15f, 0.15f, 0.015f}, 0.3f, allFaces(metal));
  b_.turnedBox(k, s, w, 0.8f, {0.015f, 0.015f, 0.8f}, 0.3f, allFaces(metal));
  Material shade;
  shade.pattern = Pattern::kCurtain;
  shade.a = Vec3f(0.92f, 0.86f, 0.72f);
  shade.b = Vec3f(0.8f, 0.7f, 0.5f);
  b_.turnedBox(k, s, w, 1.65f, {0.2f, 0.2f, 0.15f}, 0.3f, allFaces(b_.material(shade)));
}

}  // namespace synthetic
}  // namespace relocalizer
