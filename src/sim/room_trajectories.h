#pragma once
// The synthetic room's camera paths. Private to the sim module.

#include "synthetic_internal.h"

namespace relocalizer {
namespace synthetic {

// SyntheticRoom::trajectories: training and test loops around `room`'s centre.
SyntheticTrajectories roomTrajectories(const SyntheticRoom::Impl& room, int train_frames,
                                       int test_frames);

}  // namespace synthetic
}  // namespace relocalizer
