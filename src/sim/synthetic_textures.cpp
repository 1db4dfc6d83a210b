// Surface colours: procedural textures defined in each face's own metric
// (u, v) coordinates, so a surface looks the same from every viewpoint.

#include "synthetic_textures.h"

namespace relocalizer {
namespace synthetic {

Vec3f albedo(const Material& m, const std::vector<Shape>& shapes, float u, float v, float width,
             float height) {
  switch (m.pattern) {
    case Pattern::kPlain:
      // Faint large blotches, like real paint under real light: too weak for
      // colour-comparison features, which is the point.
      return m.a * (0.97f + 0.06f * fbm(u * 1.3f, v * 1.3f, m.seed, 1));

    case Pattern::kWallpaper: {
      const float grain = 0.9f + 0.2f * fbm(u * 25.0f, v * 25.0f, m.seed, 1);
      if (m.variant == 0) {  // stripes with a small repeating motif
        const float s = fract(u / m.scale);
        Vec3f c = s < 0.5f ? m.a : m.b;
        if (s > 0.5f && s < 0.53f) c = m.c;
        const float mu = fract(u / m.scale + 0.25f) - 0.5f, mv = fract(v / (m.scale * 0.8f)) - 0.5f;
        if (std::abs(mu) + std::abs(mv) < 0.12f) c = m.c;
        return c * grain;
      }
      if (m.variant == 1) {  // diamond lattice, alternate rows offset
        const float cv = v / m.scale;
        const float row = static_cast<float>(floorInt(cv));
        const float fu = fract(u / m.scale + 0.5f * (static_cast<int>(row) & 1)) - 0.5f;
        const float fv = cv - row - 0.5f;
        const float d = std::abs(fu) + std::abs(fv);
        Vec3f c = d < 0.2f ? m.b : (d > 0.3f && d < 0.36f ? m.c : m.a);
        return c * grain;
      }
      // Sponged paint with flecks.
      const float t = fbm(u * 1.6f / m.scale, v * 1.6f / m.scale, m.seed, 3);
      Vec3f c = mix(m.a, m.b, smoothstep(0.4f, 0.6f, t));
      if (valueNoise(u * 90.0f, v * 90.0f, m.seed + 5) > 0.8f) c = m.c;
      return c * grain;
    }

    case Pattern::kBrick: {
      const float bw = 0.24f, bh = 0.075f, mortar = 0.011f;
      const int row = floorInt(v / bh);
      const float su = u + ((row & 1) ? bw * 0.5f : 0.0f);
      const int col = floorInt(su / bw);
      const float fu = su - col * bw, fv = v - row * bh;
      const float speck = 0.85f + 0.3f * fbm(u * 30.0f, v * 30.0f, m.seed, 2);
      if (fu < mortar || fv < mortar) return m.c * (0.9f + 0.1f * speck);
      return mix(m.a, m.b, unitFloat(hashCell(col, row, m.seed))) * speck;
    }

    case Pattern::kPlanks: {
      const float pw = m.scale, piece = 1.1f;
      const int row = floorInt(v / pw);
      const float offset = unitFloat(hashCell(row, 7, m.seed)) * piece;
      const int idx = floorInt((u + offset) / piece);
      const float fu = u + offset - idx * piece, fv = v - row * pw;
      if (fu < 0.004f || fv < 0.004f) return m.c;
      const uint32_t plank = hashCell(idx, row, m.seed);
      const float rings =
          fv * 30.0f + 3.0f * fbm(u * 0.9f, fv * 6.0f, plank, 2) + unitFloat(plank) * 10.0f;
      const float g =
          smoothstep(0.0f, 0.3f, fract(rings)) * (1.0f - smoothstep(0.5f, 1.0f, fract(rings)));
      const float fibre = fbm(u * 4.0f, fv * 90.0f, plank + 3, 2);
      const float tone = 0.85f + 0.3f * unitFloat(plank * 0x9E3779B9U);
      return mix(m.a, m.b, 0.55f * g + 0.45f * fibre) * tone;
    }

    case Pattern::kWood: {
      // Grain follows the face's long side, as boards are cut.
      const bool along_u = width >= height;
      const float along = along_u ? u : v, across = along_u ? v : u;
      const float rings = across * 28.0f + 4.0f * fbm(along * 0.8f, across * 5.0f, m.seed, 2);
      const float g =
          smoothstep(0.0f, 0.3f, fract(rings)) * (1.0f - smoothstep(0.5f, 1.0f, fract(rings)));
      const float fibre = fbm(along * 3.0f, across * 80.0f, m.seed + 1, 2);
      return mix(m.a, m.b, 0.6f * g + 0.4f * fibre);
    }

    case Pattern::kTiles: {
      const float t = m.scale;
      const int iu = floorInt(u / t), iv = floorInt(v / t);
      const float fu = u - iu * t, fv = v - iv * t;
      if (fu < 0.005f || fv < 0.005f) return m.c;
      const Vec3f base = ((iu + iv) & 1) ? m.a : m.b;
      const float veins = fbm(u * 6.0f + 3.0f * fbm(u * 2, v * 2, m.seed, 1), v * 6.0f,
                              m.seed + static_cast<uint32_t>(iu * 31 + iv), 3);
      return base * (0.85f + 0.1f * unitFloat(hashCell(iu, iv, m.seed)) + 0.2f * veins);
    }

    case Pattern::kPoster: {
      Vec3f c;
      if (m.variant == 1)
        c = m.a * (0.7f + 0.5f * fbm(u * 70.0f, v * 70.0f, m.seed, 3));
      else
        c = mix(m.b, m.a, std::clamp(v / height, 0.0f, 1.0f));
      for (int i = m.shapes_begin; i < m.shapes_begin + m.shapes_count; ++i) {
        const Shape& s = shapes[i];
        const float dx = (u - s.x) / s.rx, dy = (v - s.y) / s.ry;
        bool inside = false;
        switch (s.kind) {
          case Shape::kDisc:
            inside = dx * dx + dy * dy < 1.0f;
            break;
          case Shape::kRect:
            inside = std::abs(dx) < 1.0f && std::abs(dy) < 1.0f;
            break;
          case Shape::kTriangle:
            inside = dy > -1.0f && dy < 1.0f && std::abs(dx) < 0.5f * (1.0f - dy);
            break;
          case Shape::kRing: {
            const float r2 = dx * dx + dy * dy;
            inside = r2 < 1.0f && r2 > 0.55f;
            break;
          }
          case Shape::kDiamond:
            inside = std::abs(dx) + std::abs(dy) < 1.0f;
            break;
        }
        if (inside) c = s.colour;
      }
      if (m.variant == 0) {  // lines of "text" along the bottom
        const float line_h = std::max(0.012f, height * 0.025f);
        const int line = floorInt(v / line_h);
        const float margin = width * 0.08f;
        if (line >= 1 && line <= 6 && (line & 1) && u > margin && u < width - margin) {
          const float word =
              fract((u - margin) / (width * 0.09f) + unitFloat(hashCell(line, 0, m.seed)));
          const int word_idx = floorInt((u - margin) / (width * 0.09f));
          if (word < 0.8f && unitFloat(hashCell(line, word_idx, m.seed)) < 0.85f) c = m.c;
        }
      }
      return c;
    }

    case Pattern::kPainting: {
      const float x = u / std::max(width, 1e-3f), y = v / std::max(height, 1e-3f);
      const float warp = fbm(x * 3.0f, y * 3.0f, m.seed, 3);
      const float t = fbm(x * 2.5f + 1.8f * warp, y * 2.5f + 1.8f * warp, m.seed + 1, 5);
      Vec3f c = t < 0.5f ? mix(m.a, m.b, smoothstep(0.3f, 0.5f, t))
                         : mix(m.b, m.c, smoothstep(0.5f, 0.7f, t));
      if (m.variant == 1) {  // a landscape: sky over hills
        const float horizon = 0.45f + 0.15f * fbm(x * 4.0f, 0.5f, m.seed + 2, 3);
        if (y > horizon) c = mix(m.c, Vec3f(0.95f, 0.95f, 0.98f), (y - horizon) * 1.5f);
      }
      return c * (0.88f + 0.24f * fbm(u * 60.0f, v * 12.0f, m.seed + 3, 2));
    }

    case Pattern::kSpine: {
      const bool upright = height >= width;
      const float along = (upright ? v : u) / std::max(upright ? height : width, 1e-3f);
      const float across = (upright ? u : v) / std::max(upright ? width : height, 1e-3f);
      Vec3f c = m.a * (0.9f + 0.15f * fbm(u * 40.0f, v * 40.0f, m.seed, 1));
      const float band = 0.06f + 0.05f * (m.variant & 1);
      if (std::abs(along - 0.12f) < band * 0.5f || std::abs(along - 0.88f) < band * 0.5f) c = m.b;
      if (m.variant >= 2 && std::abs(across - 0.5f) < 0.28f && along > 0.35f && along < 0.7f)
        c = m.c;
      return c;
    }

    case Pattern::kRug: {
      const float edge = std::min(std::min(u, width - u), std::min(v, height - v));
      const float wool = 0.85f + 0.3f * fbm(u * 80.0f, v * 80.0f, m.seed, 2);
      if (edge < 0.05f) return m.c * wool;
      if (edge < 0.16f) return (floorInt(edge / 0.035f) & 1 ? m.b : m.c) * wool;
      const float fu = std::abs(fract(u / m.scale) - 0.5f),
                  fv = std::abs(fract(v / m.scale) - 0.5f);
      const float d = fu + fv;
      const Vec3f c = d < 0.15f ? m.c : d < 0.3f ? m.b : d < 0.42f ? m.a : m.b;
      return c * wool;
    }

    case Pattern::kSky: {
      const float y = v / std::max(height, 1e-3f);
      Vec3f c = mix(Vec3f(0.85f, 0.88f, 0.92f), Vec3f(0.45f, 0.62f, 0.9f), y);
      c = mix(c, Vec3f(0.97f, 0.97f, 0.97f),
              smoothstep(0.5f, 0.7f, fbm(u * 1.5f, v * 3.5f, m.seed, 4)));
      // Distant buildings along the bottom, with lit windows.
      const int building = floorInt(u / 0.3f);
      const float top = 0.12f + 0.35f * unitFloat(hashCell(building, 1, m.seed));
      if (y < top) {
        c = Vec3f::Constant(0.35f + 0.25f * unitFloat(hashCell(building, 2, m.seed)));
        const float wu = fract(u / 0.06f), wv = fract(v / 0.08f);
        if (wu > 0.3f && wu < 0.7f && wv > 0.3f && wv < 0.75f)
          c = unitFloat(
                  hashCell(static_cast<int>(u / 0.06f), static_cast<int>(v / 0.08f), m.seed)) < 0.4f
                  ? Vec3f(0.95f, 0.85f, 0.5f)
                  : Vec3f(0.2f, 0.22f, 0.25f);
      }
      return c;
    }

    case Pattern::kScreen:
      return m.a * (0.8f + 0.4f * fbm(u * 3.0f, v * 3.0f, m.seed, 1));

    case Pattern::kClothes: {
      const float knit = 0.85f + 0.3f * fbm(u * 50.0f, v * 50.0f, m.seed, 2);
      if (m.variant == 1) {  // a checkered crate
        const int iu = floorInt(u / m.scale);
        const int iv = floorInt(v / m.scale);
        return ((iu + iv) & 1 ? m.a : m.b) * knit;
      }
      const float y = v / std::max(height, 1e-3f);
      if (y > 0.88f) return Vec3f(0.85f, 0.65f, 0.5f) * knit;  // head
      if (y < 0.47f) return m.c * knit;                        // trousers
      return (fract(v / m.scale) < 0.5f ? m.a : m.b) * knit;   // striped jumper
    }

    case Pattern::kFoliage: {
      const float leaf = fbm(u * 12.0f, v * 12.0f, m.seed, 4);
      const float gap = valueNoise(u * 35.0f, v * 35.0f, m.seed + 9);
      if (gap < 0.25f) return m.a * 0.4f;
      return mix(m.a, m.b, smoothstep(0.3f, 0.7f, leaf));
    }

    case Pattern::kSpeckle: {
      Vec3f c = m.a * (0.9f + 0.2f * fbm(u * 8.0f, v * 8.0f, m.seed, 3));
      const float n = valueNoise(u * 160.0f, v * 160.0f, m.seed + 1);
      if (n > 0.8f) c = m.b;
      if (n < 0.15f) c = m.c;
      return c;
    }

    case Pattern::kRadiator: {
      const float f = fract(u / 0.05f);
      if (v < 0.04f || v > height - 0.04f) return m.a * 0.95f;
      return m.a * (f < 0.35f ? 0.72f : 1.0f);
    }

    case Pattern::kCurtain: {
      const float folds = 0.78f + 0.22f * std::sin(u * kTwoPi / 0.11f);
      Vec3f c = m.a;
      if (m.variant == 1) {
        const float fu = fract(u / 0.08f) - 0.5f, fv = fract(v / 0.08f) - 0.5f;
        if (fu * fu + fv * fv < 0.06f) c = m.b;
      } else if (fract(v / 0.15f) < 0.25f) {
        c = m.b;
      }
      return c * folds;
    }
  }
  return m.a;
}

}  // namespace synthetic
}  // namespace relocalizer
