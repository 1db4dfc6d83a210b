#pragma once
// The inner loop of preemptive RANSAC scoring: eight pose hypotheses (lanes)
// against a batch of samples, each with its candidate modes. Kept free of
// Eigen so that its AVX2 build (one function of its own translation unit,
// chosen at run time when the CPU has AVX2) shares no inline template with
// the rest of the program: an AVX copy of an Eigen template kept by the linker
// for every caller would fault on a CPU without AVX.
//
// Both builds run the same IEEE single-precision operations in the same order
// per lane (no fused multiply-add), so they choose the same modes bit for bit;
// AVX2 does in one instruction what SSE2 does in two.

#include <cstddef>

namespace relocalizer {

constexpr int kScoreLanes = 8;

// The pose x -> R x + t of each lane: rotation[k][l] is R(k / 3, k % 3) of
// lane l, translation[k][l] is t(k).
struct LanePoses {
  alignas(32) float rotation[9][kScoreLanes];
  alignas(32) float translation[3][kScoreLanes];
};

// A batch sample: its camera point and how many candidate modes follow it in
// the batch's mode list.
struct LaneSample {
  float camera[3];
  int count;
  int sample;  // the caller's index of the sample
};

// A candidate mode: its mean and information matrix (upper triangle, row
// major: xx xy xz yy yz zz) in world coordinates.
struct LaneMode {
  float mean[3];
  float information[6];
};

// A sample that is an inlier of at least one lane: for each lane, the index
// (into the batch's mode list) of its nearest candidate under chi2, or -1.
struct LaneMatch {
  int sample;  // index into the batch
  int mode[kScoreLanes];
};

// For each of the `count` samples in order (their modes consecutive in
// `modes`), the candidate with the smallest squared Mahalanobis distance
// below `chi2` for every lane, the first of equals; writes one LaneMatch per
// sample that some lane accepts, in sample order, and returns how many.
// `matches` holds `count` entries.
size_t matchLanes(const LanePoses& poses, const LaneSample* samples, size_t count,
                  const LaneMode* modes, float chi2, LaneMatch* matches);

// The portable build and the AVX2 build of matchLanes; the AVX2 one only on a
// CPU that has AVX2 (lanesHaveAvx2).
size_t matchLanesPortable(const LanePoses& poses, const LaneSample* samples, size_t count,
                          const LaneMode* modes, float chi2, LaneMatch* matches);
size_t matchLanesAvx2(const LanePoses& poses, const LaneSample* samples, size_t count,
                      const LaneMode* modes, float chi2, LaneMatch* matches);
bool lanesHaveAvx2();

}  // namespace relocalizer
