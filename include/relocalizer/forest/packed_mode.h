#pragma once
// A leaf mode as the model keeps it in memory and on disk: 18 bytes instead of
// LeafMode's 36, for the same answers (issue 42; docs/benchmarks.md, "Models
// half the size").
//
// - The mean as three 16-bit steps of its tree's grid (ModeGrid): the tree's
//   box of means in 65535 steps, a fraction of a millimetre for a room (0.15 mm
//   over 10 m), far below the 5 cm mean-shift bandwidth.
// - The information (inverse covariance) as its upper Cholesky factor U
//   (information = U^T U) in IEEE half precision: rounding a factor keeps the
//   product positive semi-definite, where rounding the matrix itself can make
//   an elongated mode indefinite; half keeps 11 significant bits, and the
//   factor's entries (1/sigma, 1 to 100 per metre) are well inside its range.
//
// Prediction unpacks only the mode it chooses per tree (forest.h), so RANSAC
// and refinement keep reading LeafMode.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "relocalizer/forest/leaf_mode.h"

namespace relocalizer {

// Where a tree's packed means lie: mean = origin + step * q.
struct ModeGrid {
  std::array<float, 3> origin{};
  float step = 1.0f;
};
static_assert(sizeof(ModeGrid) == 16, "ModeGrid layout is part of the model format");

struct PackedMode {
  std::array<uint16_t, 3> mean{};      // steps of the tree's ModeGrid
  std::array<uint16_t, 6> cholesky{};  // U's upper triangle (00 01 02 11 12 22), half bits
};
static_assert(sizeof(PackedMode) == 18, "PackedMode layout is part of the model format");

// The grid that holds every mean of `modes` (a default grid for none).
ModeGrid modeGridOf(const std::vector<LeafMode>& modes);

// `mode` on `grid` (whose box must hold its mean); an information matrix that
// is not positive definite (never written by training) packs as zero.
PackedMode packMode(const LeafMode& mode, const ModeGrid& grid);

LeafMode unpackMode(const PackedMode& packed, const ModeGrid& grid);

// Every mode of a tree on the grid of all of them.
void packModes(const std::vector<LeafMode>& modes, ModeGrid& grid, std::vector<PackedMode>& packed);

}  // namespace relocalizer
