#include "relocalizer/pose/lane_scoring.h"

#include <cstring>

// No Eigen (nor any other shared inline code) in this file: see lane_scoring.h.
// GCC vector extensions carry the eight lanes; the portable build lowers each
// operation to two SSE2 instructions, the AVX2 build to one. Neither enables
// FMA, so `a * b + c` stays a rounded product and a rounded sum, as in the
// Eigen arrays this replaced.

namespace relocalizer {

namespace {

using Float8 = float __attribute__((vector_size(32)));
using Int8 = int __attribute__((vector_size(32)));
using Double4 = double __attribute__((vector_size(32)));
using Long4 = long long __attribute__((vector_size(32)));

// One lane statistic as two halves of four lanes.
struct Half2 {
  Double4 h[2];
  void load(const double* lanes) { std::memcpy(h, lanes, sizeof h); }
  void store(double* lanes) const { std::memcpy(lanes, h, sizeof h); }
};

// The lanes' sums in registers (or the stack) while a batch is scored.
struct Accumulators {
  Half2 count, source[3], target[3], cross[9];

  explicit Accumulators(const LaneSums& sums) {
    count.load(sums.count);
    for (int k = 0; k < 3; ++k) source[k].load(sums.source[k]);
    for (int k = 0; k < 3; ++k) target[k].load(sums.target[k]);
    for (int k = 0; k < 9; ++k) cross[k].load(sums.cross[k]);
  }
  void store(LaneSums& sums) const {
    count.store(sums.count);
    for (int k = 0; k < 3; ++k) source[k].store(sums.source[k]);
    for (int k = 0; k < 3; ++k) target[k].store(sums.target[k]);
    for (int k = 0; k < 9; ++k) cross[k].store(sums.cross[k]);
  }
};

// Inlined into both builds, so each compiles it for its own instruction set.
// A lane that takes no mode keeps its sums by selection, not by adding zero.
__attribute__((always_inline)) inline void scoreBody(const LanePoses& poses,
                                                     const LaneSample* samples, size_t count,
                                                     const LaneMode* modes, float chi2,
                                                     LaneSums& sums) {
  Float8 r[9], t[3];
  for (int k = 0; k < 9; ++k) std::memcpy(&r[k], poses.rotation[k], sizeof(Float8));
  for (int k = 0; k < 3; ++k) std::memcpy(&t[k], poses.translation[k], sizeof(Float8));
  Int8 score;
  std::memcpy(&score, sums.score, sizeof score);
  Accumulators acc(sums);
  const Float8 limit = Float8{} + chi2;
  const Int8 none = Int8{} - 1;
  int first = 0;  // the sample's first mode in `modes`
  for (size_t i = 0; i < count; ++i) {
    const LaneSample& s = samples[i];
    const float cx = s.camera[0], cy = s.camera[1], cz = s.camera[2];
    const Float8 wx = r[0] * cx + r[1] * cy + r[2] * cz + t[0];
    const Float8 wy = r[3] * cx + r[4] * cy + r[5] * cz + t[1];
    const Float8 wz = r[6] * cx + r[7] * cy + r[8] * cz + t[2];
    Float8 best = limit;
    Int8 chosen = none;
    for (int c = 0; c < s.count; ++c) {
      const LaneMode& m = modes[first + c];
      const float* in = m.information;
      const Float8 dx = wx - m.mean[0], dy = wy - m.mean[1], dz = wz - m.mean[2];
      const Float8 d = in[0] * dx * dx + in[3] * dy * dy + in[5] * dz * dz +
                       2.0f * (in[1] * dx * dy + in[2] * dx * dz + in[4] * dy * dz);
      const Int8 better = d < best;
      best = better ? d : best;
      chosen = better ? Int8{} + c : chosen;
    }
    const Int8 hit = chosen >= 0;
    bool any = false;
    for (int l = 0; l < kScoreLanes; ++l) any |= hit[l] != 0;
    if (any) {
      score -= hit;  // hit is -1 where a lane takes a mode
      const double source[3] = {cx, cy, cz};
      for (int half = 0; half < 2; ++half) {
        long long lane_mask[4];
        double lane_target[3][4];
        for (int j = 0; j < 4; ++j) {
          const int l = 4 * half + j;
          lane_mask[j] = hit[l];
          const float* mean = modes[first + (hit[l] ? chosen[l] : 0)].mean;
          for (int k = 0; k < 3; ++k) lane_target[k][j] = mean[k];
        }
        Long4 mask;
        Double4 target[3];
        std::memcpy(&mask, lane_mask, sizeof mask);
        std::memcpy(target, lane_target, sizeof target);
        Double4& n = acc.count.h[half];
        n = mask ? n + 1.0 : n;
        for (int k = 0; k < 3; ++k) {
          Double4& sum_s = acc.source[k].h[half];
          sum_s = mask ? sum_s + source[k] : sum_s;
          Double4& sum_t = acc.target[k].h[half];
          sum_t = mask ? sum_t + target[k] : sum_t;
        }
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            Double4& sum = acc.cross[3 * a + b].h[half];
            sum = mask ? sum + target[a] * source[b] : sum;
          }
      }
    }
    first += s.count;
  }
  std::memcpy(sums.score, &score, sizeof score);
  acc.store(sums);
}

}  // namespace

void scoreLanesPortable(const LanePoses& poses, const LaneSample* samples, size_t count,
                        const LaneMode* modes, float chi2, LaneSums& sums) {
  scoreBody(poses, samples, count, modes, chi2, sums);
}

__attribute__((target("avx2"))) void scoreLanesAvx2(const LanePoses& poses,
                                                    const LaneSample* samples, size_t count,
                                                    const LaneMode* modes, float chi2,
                                                    LaneSums& sums) {
  scoreBody(poses, samples, count, modes, chi2, sums);
}

bool lanesHaveAvx2() {
  static const bool has = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return has;
}

void scoreLanes(const LanePoses& poses, const LaneSample* samples, size_t count,
                const LaneMode* modes, float chi2, LaneSums& sums) {
  if (lanesHaveAvx2())
    scoreLanesAvx2(poses, samples, count, modes, chi2, sums);
  else
    scoreLanesPortable(poses, samples, count, modes, chi2, sums);
}

}  // namespace relocalizer
