#include "relocalizer/core/frame.h"

#include <cmath>
#include <limits>

namespace relocalizer {

Expected<cv::Mat> depthToMetres(const cv::Mat& raw, double units_per_metre) {
  if (raw.empty()) return makeError("depth image is empty");
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  cv::Mat out(raw.size(), CV_32FC1);
  if (raw.type() == CV_16UC1) {
    if (!(units_per_metre > 0)) return makeError("depth scale must be positive");
    const float scale = static_cast<float>(1.0 / units_per_metre);
    for (int v = 0; v < raw.rows; ++v) {
      const auto* in = raw.ptr<uint16_t>(v);
      auto* o = out.ptr<float>(v);
      for (int u = 0; u < raw.cols; ++u)
        o[u] = (in[u] == 0 || in[u] == 65535) ? kNaN : in[u] * scale;
    }
    return out;
  }
  if (raw.type() == CV_32FC1) {
    for (int v = 0; v < raw.rows; ++v) {
      const auto* in = raw.ptr<float>(v);
      auto* o = out.ptr<float>(v);
      for (int u = 0; u < raw.cols; ++u) o[u] = (std::isfinite(in[u]) && in[u] > 0) ? in[u] : kNaN;
    }
    return out;
  }
  return makeError(
      "depth must be 16-bit unsigned (millimetres) or 32-bit float (metres) with one "
      "channel, got OpenCV type " +
      std::to_string(raw.type()) + " with " + std::to_string(raw.channels()) + " channels");
}

cv::Mat depthToMillimetres(const cv::Mat& metres) {
  CV_Assert(metres.type() == CV_32FC1);
  cv::Mat out(metres.size(), CV_16UC1);
  for (int v = 0; v < metres.rows; ++v) {
    const float* in = metres.ptr<float>(v);
    uint16_t* o = out.ptr<uint16_t>(v);
    for (int u = 0; u < metres.cols; ++u) {
      const double mm =
          std::isfinite(in[u]) ? std::round(static_cast<double>(in[u]) * 1000.0) : 0.0;
      o[u] = (mm >= 1.0 && mm <= 65534.0) ? static_cast<uint16_t>(mm) : 0;
    }
  }
  return out;
}

std::string frameValidationError(const RgbdFrame& frame) {
  if (frame.colour.empty()) return "colour image is empty";
  if (frame.depth.empty()) return "depth image is empty";
  if (frame.colour.type() != CV_8UC3) return "colour image is not 8-bit BGR";
  if (frame.depth.type() != CV_32FC1) return "depth image is not 32-bit float metres";
  if (frame.colour.size() != frame.depth.size())
    return "colour (" + std::to_string(frame.colour.cols) + "x" +
           std::to_string(frame.colour.rows) + ") and depth (" + std::to_string(frame.depth.cols) +
           "x" + std::to_string(frame.depth.rows) + ") differ in size";
  const std::string camera_error = frame.camera.validationError();
  if (!camera_error.empty()) return "camera intrinsics: " + camera_error;
  if (frame.camera.width != frame.depth.cols || frame.camera.height != frame.depth.rows)
    return "camera intrinsics are for " + std::to_string(frame.camera.width) + "x" +
           std::to_string(frame.camera.height) + " but the images are " +
           std::to_string(frame.depth.cols) + "x" + std::to_string(frame.depth.rows);
  return {};
}

int countValidDepth(const cv::Mat& depth) {
  int count = 0;
  for (int v = 0; v < depth.rows; ++v) {
    const auto* d = depth.ptr<float>(v);
    for (int u = 0; u < depth.cols; ++u) count += std::isfinite(d[u]) ? 1 : 0;
  }
  return count;
}

}  // namespace relocalizer
