#pragma once
// Surface colours of the synthetic room. Private to the sim module.

#include <vector>

#include "synthetic_internal.h"

namespace relocalizer {
namespace synthetic {

// The colour (linear RGB) of material `m` at (u, v) metres on a face
// width x height metres; `shapes` holds the posters' elements.
Vec3f albedo(const Material& m, const std::vector<Shape>& shapes, float u, float v, float width,
             float height);

}  // namespace synthetic
}  // namespace relocalizer
