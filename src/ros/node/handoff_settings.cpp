#include "handoff_settings.h"

#include "../conversion/message_conversion.h"

namespace relocalizer_ros {

void readHandoffSettings(ParamReader& reader, HandoffSettings& handoff) {
  reader.read("forward_initialpose", handoff.forward_initialpose);
  reader.read("set_pose_service", handoff.set_pose_service);
  reader.read("handoff_frame", handoff.handoff_frame);
  handoff.handoff_frame = stripLeadingSlashes(handoff.handoff_frame);
}

}  // namespace relocalizer_ros
