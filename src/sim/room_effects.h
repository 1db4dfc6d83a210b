#pragma once
// The synthetic room's time-varying effects. Private to the sim module.

#include "synthetic_internal.h"

namespace relocalizer {
namespace synthetic {

// What frame `frame_index`'s lighting and moving objects are in `room` under
// `effects`: the same for a frame whenever it is rendered.
SyntheticRoom::Impl::FrameState frameState(const SyntheticRoom::Impl& room, int frame_index,
                                           const RenderEffects& effects);

}  // namespace synthetic
}  // namespace relocalizer
