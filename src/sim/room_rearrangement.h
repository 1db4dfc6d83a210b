#pragma once
// A look-alike room's layout. Private to the sim module.

#include "room_builder.h"
#include "room_layout.h"

namespace relocalizer {
namespace synthetic {

// The same furniture and decorations as `record`, moved to other places drawn
// from `builder`'s generator, and new camera path phases. The boxes keep their
// sizes, materials and texture coordinates (a piece moved to another wall
// turns with it), so each piece looks exactly as before. `record` then says
// where the pieces are.
void rearrange(RoomBuilder& builder, FurnishingRecord& record);

// Up to `count` pieces of furniture of `record`, tried in `order` (indices
// into record.furniture), moved at least 0.5 m along their wall or to another
// where the walls are free, drawn from `builder`'s generator (a piece with no
// such place stays); returns how many moved.
int moveFurniture(RoomBuilder& builder, FurnishingRecord& record, const std::vector<int>& order,
                  int count);

}  // namespace synthetic
}  // namespace relocalizer
