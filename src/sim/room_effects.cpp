// The room's time-varying effects: what a frame's lighting and moving objects
// are at its index (RenderEffects), the same for a frame whenever it is rendered.

#include <cmath>

#include "room_effects.h"

namespace relocalizer {
namespace synthetic {

SyntheticRoom::Impl::FrameState frameState(const SyntheticRoom::Impl& room, int frame_index,
                                           const RenderEffects& effects) {
  SyntheticRoom::Impl::FrameState s;
  s.ambient = room.ambient;
  s.light_colour = {room.lights[0].colour, room.lights[1].colour};
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
    const Vec3f centre = (room.lo + room.hi) * 0.5f;
    const float rx = (room.hi.x() - room.lo.x()) / 2 - 0.85f,
                ry = (room.hi.y() - room.lo.y()) / 2 - 0.85f;
    const struct {
      double phase, speed;
      Vec3f half;
      int material;
    } movers[2] = {{room.phases[7], -0.011, {0.2f, 0.12f, 0.85f}, room.person_material},
                   {room.phases[7] + M_PI, 0.007, {0.25f, 0.18f, 0.35f}, room.cart_material}};
    for (int i = 0; i < 2; ++i) {
      const double a = movers[i].phase + movers[i].speed * t;
      Box& box = s.movers[i];
      box.centre = Vec3f(centre.x() + rx * static_cast<float>(std::cos(a)),
                         centre.y() + ry * static_cast<float>(std::sin(a)), movers[i].half.z());
      box.half = movers[i].half;
      const float heading = static_cast<float>(a + M_PI / 2);  // along the path
      box.cos_yaw = std::cos(heading);
      box.sin_yaw = std::sin(heading);
      box.rotated = true;
      box.material = allFaces(movers[i].material);
      box.id = -1 - i;
    }
    s.mover_count = 2;
  }
  return s;
}

}  // namespace synthetic
}  // namespace relocalizer
