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

// Inlined into both builds, so each compiles it for its own instruction set.
__attribute__((always_inline)) inline size_t matchBody(const LanePoses& poses,
                                                       const LaneSample* samples, size_t count,
                                                       const LaneMode* modes, float chi2,
                                                       LaneMatch* matches) {
  Float8 r[9], t[3];
  for (int k = 0; k < 9; ++k) std::memcpy(&r[k], poses.rotation[k], sizeof(Float8));
  for (int k = 0; k < 3; ++k) std::memcpy(&t[k], poses.translation[k], sizeof(Float8));
  const Float8 limit = Float8{} + chi2;
  const Int8 none = Int8{} - 1;
  size_t found = 0;
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
      chosen = better ? Int8{} + (first + c) : chosen;
    }
    bool any = false;
    for (int l = 0; l < kScoreLanes; ++l) any |= chosen[l] >= 0;
    if (any) {
      LaneMatch& match = matches[found++];
      match.sample = static_cast<int>(i);
      for (int l = 0; l < kScoreLanes; ++l) match.mode[l] = chosen[l];
    }
    first += s.count;
  }
  return found;
}

}  // namespace

size_t matchLanesPortable(const LanePoses& poses, const LaneSample* samples, size_t count,
                          const LaneMode* modes, float chi2, LaneMatch* matches) {
  return matchBody(poses, samples, count, modes, chi2, matches);
}

__attribute__((target("avx2"))) size_t matchLanesAvx2(const LanePoses& poses,
                                                      const LaneSample* samples, size_t count,
                                                      const LaneMode* modes, float chi2,
                                                      LaneMatch* matches) {
  return matchBody(poses, samples, count, modes, chi2, matches);
}

bool lanesHaveAvx2() {
  static const bool has = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return has;
}

size_t matchLanes(const LanePoses& poses, const LaneSample* samples, size_t count,
                  const LaneMode* modes, float chi2, LaneMatch* matches) {
  return lanesHaveAvx2() ? matchLanesAvx2(poses, samples, count, modes, chi2, matches)
                         : matchLanesPortable(poses, samples, count, modes, chi2, matches);
}

}  // namespace relocalizer
