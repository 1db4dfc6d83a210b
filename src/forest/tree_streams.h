#pragma once
// A forest's trees in the model file (layout: relocalizer/forest/model_io.h):
// each tree's arrays byte plane by byte plane and deflated, and the layouts of
// older versions converted as they load.

#include <cstdint>
#include <string>
#include <vector>

#include "relocalizer/core/byte_io.h"
#include "relocalizer/forest/forest.h"
#include "relocalizer/forest/model_io.h"

namespace relocalizer::detail {

// One tree as the current format stores it: uint32 nodes, uint32 modes, its
// ModeGrid, uint64 stored size, then the deflated stream.
std::vector<uint8_t> packTree(const Tree& tree);

// The trees of one forest of format `version` (1 to kModelFormatVersion),
// checked so that prediction cannot read out of bounds; false with `why` (or
// an empty `why`: truncated) when they are not a forest's.
bool readTrees(ByteReader& r, Forest& forest, uint32_t version, std::string& why);

}  // namespace relocalizer::detail
