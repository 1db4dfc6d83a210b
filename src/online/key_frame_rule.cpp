#include "relocalizer/online/key_frame_rule.h"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

namespace relocalizer {

Expected<KeyFrameMotion> parseMinMotion(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return makeError("bad --min-motion '" + text + "': " + why +
                     " (expected METRES,DEGREES such as 0.05,5; 0 turns selection off)");
  };
  std::vector<double> values;
  if (!text.empty() && text.back() == ',') return bad("empty item");
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (item.empty()) return bad("empty item");
    size_t used = 0;
    double value = 0;
    try {
      value = std::stod(item, &used);
    } catch (const std::exception&) {
      return bad("'" + item + "' is not a number");
    }
    if (used != item.size()) return bad("'" + item + "' is not a number");
    if (!std::isfinite(value) || value < 0) return bad("'" + item + "' must be finite and >= 0");
    values.push_back(value);
  }
  if (values.empty() || values.size() > 2) return bad("expected one or two numbers");
  return KeyFrameMotion{values[0], values.size() > 1 ? values[1] : 0.0};
}

std::string formatMinMotion(const KeyFrameMotion& motion) {
  char text[64];
  std::snprintf(text, sizeof text, "%g,%g", motion.metres, motion.degrees);
  return text;
}

double keyFrameDistance(const Pose& a, const Pose& b) {
  const KeyFrameMotion step;
  return translationError(a, b) / step.metres + rotationErrorDegrees(a, b) / step.degrees;
}

bool KeyFrameSelector::keep(const Pose& pose) {
  if (active() && last_) {
    const bool moved = motion_.metres > 0 && translationError(pose, *last_) >= motion_.metres;
    const bool turned =
        motion_.degrees > 0 && rotationErrorDegrees(pose, *last_) >= motion_.degrees;
    if (!moved && !turned) return false;
  }
  last_ = pose;
  return true;
}

}  // namespace relocalizer
