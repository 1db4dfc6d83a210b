#pragma once
// The inner loop of preemptive RANSAC scoring: eight pose hypotheses (lanes)
// against a batch of samples, each with its candidate modes. Kept free of
// Eigen so that its AVX2 build (one function of its own translation unit,
// chosen at run time when the CPU has AVX2) shares no inline template with
// the rest of the program: an AVX copy of an Eigen template kept by the linker
// for every caller would fault on a CPU without AVX.
//
// Both builds run the same IEEE operations in the same order per lane (float
// for the distances, double for the sums, no fused multiply-add), so they
// choose the same modes and reach the same sums bit for bit; AVX2 does in one
// instruction what SSE2 does in two.

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

// Each lane's inliers: their number and, as AlignmentSums holds them
// (rigid_alignment.h), the sums of their camera points (source), of their
// chosen modes' means (target) and of target source^T (cross, row major),
// in double.
struct LaneSums {
  alignas(32) int score[kScoreLanes];
  alignas(32) double count[kScoreLanes];
  alignas(32) double source[3][kScoreLanes];
  alignas(32) double target[3][kScoreLanes];
  alignas(32) double cross[9][kScoreLanes];
};

// For each of the `count` samples in order (their modes consecutive in
// `modes`), every lane takes the candidate with the smallest squared
// Mahalanobis distance below `chi2`, the first of equals, and adds the sample
// and that mode's mean to its sums; a lane with no such candidate leaves its
// sums as they are. The additions per lane are those of AlignmentSums::add,
// in sample order.
void scoreLanes(const LanePoses& poses, const LaneSample* samples, size_t count,
                const LaneMode* modes, float chi2, LaneSums& sums);

// The portable build and the AVX2 build of scoreLanes; the AVX2 one only on a
// CPU that has AVX2 (lanesHaveAvx2).
void scoreLanesPortable(const LanePoses& poses, const LaneSample* samples, size_t count,
                        const LaneMode* modes, float chi2, LaneSums& sums);
void scoreLanesAvx2(const LanePoses& poses, const LaneSample* samples, size_t count,
                    const LaneMode* modes, float chi2, LaneSums& sums);
bool lanesHaveAvx2();

}  // namespace relocalizer
