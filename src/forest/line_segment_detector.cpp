#include "relocalizer/forest/line_segment_detector.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace relocalizer {

namespace {

// The paper's constants. Pixels are aligned with a region when their gradient
// directions differ by at most tau = 22.5 degrees, so a pixel of pure noise is
// aligned with probability p = tau / 180 degrees = 1/8 (a power of two: its
// powers are exact).
constexpr double kCosTolerance = 0.92387953251128674;  // cos(22.5 degrees)
constexpr double kAlignedProbability = 0.125;
// Gradients of at most 2 / sin(tau) grey levels are dominated by the 8-bit
// quantisation (the paper's q = 2) and have no direction. Squared and in the
// doubled units of gradientAt(): (2 * 2 / sin(tau))^2 = 109.25.
constexpr int kMaxUndefinedGradient2 = 109;
constexpr int kMagnitudeBins = 1024;
// A rectangle with fewer of its pixels in the region than this is shrunk
// around its seed (the region curved or merged with another one).
constexpr double kMinDensity = 0.7;
// Precisions a full LSD tries per rectangle; part of the number of tests.
constexpr double kPrecisionsTested = 11.0;

struct Gradients {
  int cols = 0, rows = 0;
  std::vector<int> norm2;           // squared, doubled units; 0 where undefined
  std::vector<double> ux, uy;       // unit gradient direction, where defined
  std::vector<unsigned char> used;  // also set where the gradient is undefined
  bool defined(int i) const { return norm2[i] > 0; }
};

// The 2x2 gradient at the centre of pixels (x, y), (x + 1, y), (x, y + 1),
// (x + 1, y + 1), doubled so that it stays an integer.
Gradients gradientsOf(const cv::Mat& grey) {
  Gradients g;
  g.cols = grey.cols;
  g.rows = grey.rows;
  const size_t n = static_cast<size_t>(g.cols) * g.rows;
  g.norm2.assign(n, 0);
  g.ux.assign(n, 0.0);
  g.uy.assign(n, 0.0);
  g.used.assign(n, 1);
  for (int y = 0; y + 1 < g.rows; ++y) {
    const unsigned char* top = grey.ptr<unsigned char>(y);
    const unsigned char* bottom = grey.ptr<unsigned char>(y + 1);
    for (int x = 0; x + 1 < g.cols; ++x) {
      const int gx = (top[x + 1] + bottom[x + 1]) - (top[x] + bottom[x]);
      const int gy = (bottom[x] + bottom[x + 1]) - (top[x] + top[x + 1]);
      const int norm2 = gx * gx + gy * gy;
      if (norm2 <= kMaxUndefinedGradient2) continue;
      const size_t i = static_cast<size_t>(y) * g.cols + x;
      const double norm = std::sqrt(static_cast<double>(norm2));
      g.norm2[i] = norm2;
      g.ux[i] = gx / norm;
      g.uy[i] = gy / norm;
      g.used[i] = 0;
    }
  }
  return g;
}

// Seeds from the strongest gradient down, by 1024 bins of magnitude (the
// paper's pseudo-ordering); within a bin in raster order, so the order is
// fixed.
std::vector<int> seedOrder(const Gradients& g) {
  const int max_norm2 = *std::max_element(g.norm2.begin(), g.norm2.end());
  std::vector<int> bin_of(g.norm2.size(), -1), count(kMagnitudeBins + 1, 0);
  if (max_norm2 == 0) return {};
  const double max_norm = std::sqrt(static_cast<double>(max_norm2));
  for (size_t i = 0; i < g.norm2.size(); ++i) {
    if (!g.defined(static_cast<int>(i))) continue;
    const double share = std::sqrt(static_cast<double>(g.norm2[i])) / max_norm;
    const int bin = std::min(kMagnitudeBins - 1, static_cast<int>(share * kMagnitudeBins));
    bin_of[i] = kMagnitudeBins - 1 - bin;  // strongest first
    ++count[bin_of[i] + 1];
  }
  for (int b = 0; b < kMagnitudeBins; ++b) count[b + 1] += count[b];
  std::vector<int> order(count[kMagnitudeBins]);
  for (size_t i = 0; i < bin_of.size(); ++i)
    if (bin_of[i] >= 0) order[count[bin_of[i]]++] = static_cast<int>(i);
  return order;
}

struct Region {
  std::vector<int> pixels;      // in the order they joined
  double dir_x = 0, dir_y = 0;  // the region's gradient direction, unit
};

// 8-connected growth from `seed`: a pixel joins when its gradient is within
// tau of the region's mean direction, which follows every new member.
void growRegion(Gradients& g, int seed, Region& region) {
  region.pixels.assign(1, seed);
  g.used[seed] = 1;
  double sum_x = g.ux[seed], sum_y = g.uy[seed], norm = 1.0;
  for (size_t next = 0; next < region.pixels.size(); ++next) {
    const int x = region.pixels[next] % g.cols, y = region.pixels[next] / g.cols;
    for (int ny = std::max(0, y - 1); ny <= std::min(g.rows - 1, y + 1); ++ny)
      for (int nx = std::max(0, x - 1); nx <= std::min(g.cols - 1, x + 1); ++nx) {
        const int i = ny * g.cols + nx;
        if (g.used[i] || g.ux[i] * sum_x + g.uy[i] * sum_y < kCosTolerance * norm) continue;
        g.used[i] = 1;
        region.pixels.push_back(i);
        sum_x += g.ux[i];
        sum_y += g.uy[i];
        norm = std::sqrt(sum_x * sum_x + sum_y * sum_y);
      }
  }
  region.dir_x = sum_x / norm;
  region.dir_y = sum_y / norm;
}

struct Rect {
  double cx = 0, cy = 0;  // centre
  double dx = 0, dy = 0;  // unit direction along the segment
  double half_length = 0, half_width = 0;
  double spread = 0;  // across the segment, from the first pixel centre to the last
  double length() const { return 2.0 * half_length; }
};

// The rectangle of the paper: centre and axis from the region's pixels
// weighted by gradient magnitude (axis of largest inertia), oriented along the
// region's level line, as long as the region and as wide as its spread.
Rect rectangleOf(const Gradients& g, const Region& region) {
  double sum_w = 0, sum_x = 0, sum_y = 0;
  for (int i : region.pixels) {
    const double w = std::sqrt(static_cast<double>(g.norm2[i]));
    sum_w += w;
    sum_x += w * (i % g.cols);
    sum_y += w * (i / g.cols);
  }
  Rect r;
  const double mx = sum_x / sum_w, my = sum_y / sum_w;
  double sxx = 0, syy = 0, sxy = 0;
  for (int i : region.pixels) {
    const double w = std::sqrt(static_cast<double>(g.norm2[i]));
    const double ex = (i % g.cols) - mx, ey = (i / g.cols) - my;
    sxx += w * ex * ex;
    syy += w * ey * ey;
    sxy += w * ex * ey;
  }
  const double half_diff = 0.5 * (sxx - syy);
  const double largest = 0.5 * (sxx + syy) + std::sqrt(half_diff * half_diff + sxy * sxy);
  // Two forms of the same eigenvector; the longer is the better conditioned.
  double ax = largest - syy, ay = sxy, bx = sxy, by = largest - sxx;
  if (bx * bx + by * by > ax * ax + ay * ay) ax = bx, ay = by;
  const double axis_norm = std::sqrt(ax * ax + ay * ay);
  if (axis_norm == 0.0) {  // isotropic: the level line decides
    ax = -region.dir_y;
    ay = region.dir_x;
  } else {
    ax /= axis_norm;
    ay /= axis_norm;
  }
  if (ax * -region.dir_y + ay * region.dir_x < 0.0) ax = -ax, ay = -ay;
  r.dx = ax;
  r.dy = ay;
  double l_min = 0, l_max = 0, w_min = 0, w_max = 0;
  for (int i : region.pixels) {
    const double ex = (i % g.cols) - mx, ey = (i / g.cols) - my;
    const double l = ex * ax + ey * ay, w = ey * ax - ex * ay;
    l_min = std::min(l_min, l);
    l_max = std::max(l_max, l);
    w_min = std::min(w_min, w);
    w_max = std::max(w_max, w);
  }
  // Across the segment the centre stays on the weighted centroid: the
  // strongest gradients mark the edge better than the middle of the region.
  const double l_mid = 0.5 * (l_min + l_max);
  r.cx = mx + l_mid * ax;
  r.cy = my + l_mid * ay;
  r.half_length = 0.5 * (l_max - l_min);
  r.spread = w_max - w_min;
  r.half_width = 0.5 * std::max(1.0, r.spread);
  return r;
}

// The paper's density: region pixels per unit area of the rectangle spanned
// by the extreme pixel centres (at least 1 px each way).
double density(const Region& region, const Rect& r) {
  return region.pixels.size() / (std::max(1.0, r.length()) * std::max(1.0, r.spread));
}

// The paper's region radius reduction: while the rectangle is too sparse, drop
// the region's pixels farther from the seed than 3/4 of the farthest and fit
// again (they become seeds and members of later regions again). False when
// the region falls apart.
bool shrinkUntilDense(Gradients& g, Region& region, Rect& r) {
  const int seed = region.pixels.front();
  const double sx = seed % g.cols, sy = seed / g.cols;
  while (density(region, r) < kMinDensity) {
    double far2 = 0;
    for (int i : region.pixels) {
      const double ex = (i % g.cols) - sx, ey = (i / g.cols) - sy;
      far2 = std::max(far2, ex * ex + ey * ey);
    }
    const double keep2 = far2 * (0.75 * 0.75);
    size_t kept = 0;
    for (int i : region.pixels) {
      const double ex = (i % g.cols) - sx, ey = (i / g.cols) - sy;
      if (ex * ex + ey * ey <= keep2)
        region.pixels[kept++] = i;
      else
        g.used[i] = 0;
    }
    region.pixels.resize(kept);
    if (kept < 2) return false;
    r = rectangleOf(g, region);
  }
  return true;
}

// A probability in two parts, mantissa * 2^exponent, so that long products of
// small factors neither underflow nor need a logarithm, and two of them
// compare exactly.
struct Scaled {
  double mantissa = 0.5;  // in [0.5, 1) once normalised
  int exponent = 1;
  void times(double f) {
    int e = 0;
    mantissa = std::frexp(mantissa * f, &e);
    exponent += e;
  }
  bool operator<(const Scaled& o) const {
    return exponent != o.exponent ? exponent < o.exponent : mantissa < o.mantissa;
  }
  bool belowOne() const { return exponent <= 0; }
};

// The precisions a rectangle is tried at: tau / 2^level, with cos(tau / 2^level)
// and the chance 1 / 2^(level + 3) that a noise pixel is that well aligned.
constexpr int kPrecisionLevels = 6;
constexpr double kCosOfLevel[kPrecisionLevels] = {kCosTolerance,       0.98078528040323043,
                                                  0.99518472667219693, 0.99879545620517241,
                                                  0.99969881869620425, 0.99992470183914454};

// NFA = tests * P[Binomial(n, p) >= k]: how often k aligned pixels among n
// would be seen by chance. Only exact operations and correctly rounded + - * /
// in a fixed order, so the value is the same everywhere.
Scaled falseAlarms(int n, int k, int level, double tests) {
  Scaled nfa;
  const double p = std::ldexp(kAlignedProbability, -level), q = 1.0 - p;
  if (k <= n * p) return nfa;  // at or below the mean: the tail is about 1/2 or more; 1 will do
  nfa.mantissa = 1.0;
  nfa.exponent = 0;
  // P[X = k] = C(n, k) p^k q^(n - k), then the tail relative to it: above the
  // mean each term is smaller than the last, so it is summed until the terms
  // stop counting.
  // Factors stay within 1e-7..1e4, so 16 of them fit a double between
  // normalisations.
  for (int i = 1; i <= k; i += 16) {
    double product = 1.0;
    for (int j = i; j < i + 16 && j <= k; ++j) product *= static_cast<double>(n - k + j) / j * p;
    nfa.times(product);
  }
  Scaled power, q_power;  // q^(n - k) by squaring
  power.mantissa = q_power.mantissa = 1.0;
  power.exponent = q_power.exponent = 0;
  q_power.times(q);
  for (int e = n - k; e > 0; e >>= 1) {
    if (e & 1) power.times(q_power.mantissa), power.exponent += q_power.exponent;
    q_power.exponent *= 2;
    q_power.times(q_power.mantissa);
  }
  nfa.times(power.mantissa);
  nfa.exponent += power.exponent;
  double tail = 1.0, term = 1.0;
  for (int i = k; i < n; ++i) {
    term *= static_cast<double>(n - i) / (i + 1) * (p / q);
    tail += term;
    if (term < tail * 1e-17) break;
  }
  nfa.times(tail * tests);
  return nfa;
}

// The NFA of a rectangle at a precision level: the image's pixels whose
// centres lie in it, and those of them whose gradient is that close to the
// rectangle's.
Scaled rectangleFalseAlarms(const Gradients& g, const Rect& r, int level, double tests) {
  int n = 0, k = 0;
  const double ex = r.half_length + 0.5;  // the end pixels' own half
  const double reach_y = ex * std::abs(r.dy) + r.half_width * std::abs(r.dx);
  const int y0 = std::max(0, static_cast<int>(std::floor(r.cy - reach_y)));
  const int y1 = std::min(g.rows - 1, static_cast<int>(std::ceil(r.cy + reach_y)));
  const double gx = r.dy, gy = -r.dx, cos_level = kCosOfLevel[level];
  for (int y = y0; y <= y1; ++y) {
    // The row's span inside both slabs (along and across), a pixel wider
    // than needed; the exact test below decides.
    const double oy = y - r.cy;
    double lo = -1e9, hi = 1e9;
    const auto slab = [&](double a, double b, double half) {
      if (std::abs(a) < 1e-9) return;
      const double u = (-half - b * oy) / a, v = (half - b * oy) / a;
      lo = std::max(lo, std::min(u, v));
      hi = std::min(hi, std::max(u, v));
    };
    slab(r.dx, r.dy, ex);
    slab(-r.dy, r.dx, r.half_width);
    const int xa = std::max(0, static_cast<int>(std::floor(r.cx + std::max(lo, -1e6))) - 1);
    const int xb = std::min(g.cols - 1, static_cast<int>(std::ceil(r.cx + std::min(hi, 1e6))) + 1);
    for (int x = xa; x <= xb; ++x) {
      const double ox = x - r.cx;
      if (std::abs(ox * r.dx + oy * r.dy) > ex || std::abs(oy * r.dx - ox * r.dy) > r.half_width)
        continue;
      ++n;
      const int i = y * g.cols + x;
      if (g.defined(i) && g.ux[i] * gx + g.uy[i] * gy >= cos_level) ++k;
    }
  }
  return falseAlarms(n, k, level, tests);
}

// The paper's rectangle improvement, for rectangles not yet meaningful: finer
// precisions, then a narrower rectangle, then each long side moved in, then
// finer precisions again, each change kept when it lowers the NFA. Returns the
// lowest NFA found; `r` and `level` become its rectangle.
Scaled improveRectangle(const Gradients& g, Rect& r, int& level, double tests) {
  constexpr double kStep = 0.5;  // pixels off the width per try
  level = 0;
  Scaled best = rectangleFalseAlarms(g, r, level, tests);
  const auto tryFinerPrecisions = [&] {
    for (int finer = level + 1; finer < kPrecisionLevels && !best.belowOne(); ++finer) {
      const Scaled nfa = rectangleFalseAlarms(g, r, finer, tests);
      if (nfa < best) best = nfa, level = finer;
    }
  };
  // side: 0 narrows both long sides, +1 / -1 moves one of them in.
  const auto tryNarrower = [&](int side) {
    Rect t = r;
    for (int step = 0; step < 5 && !best.belowOne() && 2.0 * t.half_width - kStep >= 0.5; ++step) {
      t.half_width -= 0.5 * kStep;
      t.cx += side * 0.5 * kStep * -t.dy;
      t.cy += side * 0.5 * kStep * t.dx;
      const Scaled nfa = rectangleFalseAlarms(g, t, level, tests);
      if (nfa < best) best = nfa, r = t;
    }
  };
  if (best.belowOne()) return best;
  tryFinerPrecisions();
  tryNarrower(0);
  tryNarrower(1);
  tryNarrower(-1);
  tryFinerPrecisions();
  return best;
}

}  // namespace

std::vector<LineSegment> detectLineSegments(const cv::Mat& grey, bool validate) {
  if (grey.type() != CV_8UC1)
    throw std::invalid_argument("detectLineSegments: expected an 8-bit one-channel image");
  std::vector<LineSegment> segments;
  if (grey.cols < 2 || grey.rows < 2) return segments;
  Gradients g = gradientsOf(grey);
  // Number of tests: every rectangle of the image (about (cols * rows)^(5/2))
  // at every precision tried.
  const double area = static_cast<double>(grey.cols) * grey.rows;
  const double tests = area * area * std::sqrt(area) * kPrecisionsTested;
  // Regions smaller than this cannot be meaningful even if all their pixels
  // are aligned: tests * p^size >= 1.
  int min_region = 0;
  for (double bound = tests; bound >= 1.0; bound *= kAlignedProbability) ++min_region;
  // Unvalidated, the paper's and OpenCV's bound, int(log8(tests)): one less,
  // and the regions OpenCV's LSD_REFINE_NONE keeps.
  if (!validate) --min_region;
  Region region;
  for (int seed : seedOrder(g)) {
    if (g.used[seed]) continue;
    growRegion(g, seed, region);
    if (static_cast<int>(region.pixels.size()) < min_region) continue;
    Rect r = rectangleOf(g, region);
    if (validate) {
      if (!shrinkUntilDense(g, region, r) || static_cast<int>(region.pixels.size()) < min_region)
        continue;
      // The improved rectangle only validates: moving a side in moves the
      // line off the centroid of the gradients, a quarter pixel a step.
      Rect validated = r;
      int level = 0;
      if (!improveRectangle(g, validated, level, tests).belowOne()) continue;
    }
    // The gradient belongs to the centre of its 2x2 block: half a pixel on.
    LineSegment s;
    s.x1 = r.cx - r.half_length * r.dx + 0.5;
    s.y1 = r.cy - r.half_length * r.dy + 0.5;
    s.x2 = r.cx + r.half_length * r.dx + 0.5;
    s.y2 = r.cy + r.half_length * r.dy + 0.5;
    s.width = 2.0 * r.half_width;
    s.region_pixels = static_cast<int>(region.pixels.size());
    segments.push_back(s);
  }
  return segments;
}

}  // namespace relocalizer
