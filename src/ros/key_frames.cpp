#include "key_frames.h"

#include <cmath>
#include <sstream>
#include <vector>

#include "relocalizer/core/pose.h"

namespace relocalizer_ros {

using relocalizer::makeError;

relocalizer::Expected<std::pair<double, double>> parseMinMotion(const std::string& text) {
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
  return std::pair<double, double>(values[0], values.size() > 1 ? values[1] : 0.0);
}

bool KeyFrameSelector::keep(const relocalizer::Pose& pose) {
  if (active() && last_) {
    const bool moved =
        min_translation_ > 0 && relocalizer::translationError(pose, *last_) >= min_translation_;
    const bool turned = min_rotation_degrees_ > 0 &&
                        relocalizer::rotationErrorDegrees(pose, *last_) >= min_rotation_degrees_;
    if (!moved && !turned) return false;
  }
  last_ = pose;
  return true;
}

}  // namespace relocalizer_ros
