// The room's time-varying effects: what a frame's lighting and moving objects
// are at its index (RenderEffects), the same for a frame whenever it is rendered.

#include <cmath>

#include "room_effects.h"

namespace relocalizer {
namespace synthetic {

namespace {

using Walker = SyntheticRoom::Impl::Walker;

// `walker` at time t, as the frame's next moving box.
void addMover(const SyntheticRoom::Impl& room, const Walker& walker, double t,
              SyntheticRoom::Impl::FrameState& s) {
  const Vec3f centre = (room.lo + room.hi) * 0.5f;
  const float rx = (room.hi.x() - room.lo.x()) / 2 - walker.inset,
              ry = (room.hi.y() - room.lo.y()) / 2 - walker.inset;
  const double a = walker.phase + walker.speed * t;
  Box& box = s.movers[s.mover_count];
  box.centre = Vec3f(centre.x() + rx * static_cast<float>(std::cos(a)),
                     centre.y() + ry * static_cast<float>(std::sin(a)), walker.half.z());
  box.half = walker.half;
  const float heading = static_cast<float>(a + M_PI / 2);  // along the path
  box.cos_yaw = std::cos(heading);
  box.sin_yaw = std::sin(heading);
  box.rotated = true;
  box.material = allFaces(walker.material);
  box.id = -1 - s.mover_count;
  ++s.mover_count;
}

}  // namespace

SyntheticRoom::Impl::FrameState frameState(const SyntheticRoom::Impl& room, int frame_index,
                                           const RenderEffects& effects) {
  SyntheticRoom::Impl::FrameState s;
  s.ambient = room.ambient;
  for (int i = 0; i < room.light_count; ++i) s.light_colour[i] = room.lights[i].colour;
  s.gain = Vec3f::Ones();
  const double t = frame_index;
  if (effects.illumination_change) {
    // Slow, incommensurate periods so no two frames light the room alike.
    const float gain =
        static_cast<float>(1.0 + 0.25 * std::sin(kTwoPi * t / 157.0 + room.phases[0]));
    s.gain = gain *
             Vec3f(static_cast<float>(1.0 + 0.07 * std::sin(kTwoPi * t / 211.0 + room.phases[1])),
                   static_cast<float>(1.0 + 0.07 * std::sin(kTwoPi * t / 193.0 + room.phases[2])),
                   static_cast<float>(1.0 + 0.07 * std::sin(kTwoPi * t / 229.0 + room.phases[3])));
    for (int i = 0; i < 2; ++i)
      s.light_colour[i] *= static_cast<float>(
          1.0 + 0.6 * std::sin(kTwoPi * t / (97.0 + 40 * i) + room.phases[4 + i]));
    s.ambient *= static_cast<float>(1.0 + 0.2 * std::sin(kTwoPi * t / 131.0 + room.phases[6]));
  }
  if (effects.moving_objects) {
    // A person and a crate going round the free floor between the camera
    // paths (1.6 m or more from the walls) and the furniture (up to 0.65 m
    // deep, chairs a little further), in opposite directions so they cross
    // the camera's view now and then.
    const Walker movers[2] = {
        {room.phases[7], -0.011, 0.85f, {0.2f, 0.12f, 0.85f}, room.person_material},
        {room.phases[7] + M_PI, 0.007, 0.85f, {0.25f, 0.18f, 0.35f}, room.cart_material}};
    for (const Walker& mover : movers) addMover(room, mover, t, s);
  }
  for (const Walker& person : room.people) addMover(room, person, t, s);
  return s;
}

}  // namespace synthetic
}  // namespace relocalizer
