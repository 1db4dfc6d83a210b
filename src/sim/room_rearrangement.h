#pragma once
// A look-alike room's layout. Private to the sim module.

#include "room_builder.h"
#include "room_layout.h"

namespace relocalizer {
namespace synthetic {

// The same furniture and decorations as `record`, moved to other places drawn
// from `builder`'s generator, and new camera path phases. The boxes keep their
// sizes, materials and texture coordinates (a piece moved to another wall
// turns with it), so each piece looks exactly as before.
void rearrange(RoomBuilder& builder, const FurnishingRecord& record);

}  // namespace synthetic
}  // namespace relocalizer
