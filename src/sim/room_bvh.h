#pragma once
// The BVH that the synthetic room's rays traverse. Private to the sim module.

#include <vector>

#include "synthetic_internal.h"

namespace relocalizer {
namespace synthetic {

// The four-wide BVH over `boxes`, which it reorders so that each leaf's boxes
// lie side by side.
std::vector<WideNode> buildBvh(std::vector<Box>& boxes);

}  // namespace synthetic
}  // namespace relocalizer
