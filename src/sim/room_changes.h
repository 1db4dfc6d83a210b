#pragma once
// A room changed after training (SceneChanges): furniture moved, decorations
// and small objects taken away, decorations added, a light switched, people
// walking through. Private to the sim module.

#include "synthetic_internal.h"

namespace relocalizer {
namespace synthetic {

// Applies valid `changes` to a copy of a built room: its boxes back in their
// creation order, changed, and a new BVH over them.
void applyChanges(SyntheticRoom::Impl& room, const SceneChanges& changes);

}  // namespace synthetic
}  // namespace relocalizer
