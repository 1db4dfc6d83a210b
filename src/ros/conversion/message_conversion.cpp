#include "message_conversion.h"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <opencv2/core.hpp>
#include <vector>

#include "relocalizer/core/outside_text.h"
#include "relocalizer/core/statistics.h"

namespace relocalizer_ros {

namespace {

namespace enc = sensor_msgs::image_encodings;

// A camera_info whose pinhole field of view falls outside this is no RGB-D
// camera's: depth sensors see about 55 to 120 degrees (Kinect 57, RealSense
// D435 87, Azure Kinect wide 120) and a rectified image never nears 180. A
// focal length 1000 times too small or too large lands outside; the lower
// bound is far below any depth camera so that crops and small images pass.
constexpr double kMinFieldOfViewDeg = 0.5;
constexpr double kMaxFieldOfViewDeg = 160.0;
// RGB-D sensors read to about 10-20 m, so a median valid 32FC1 depth beyond
// this is not metres; millimetres in floats (a common driver slip: 16UC1
// values copied as they are) put any scene farther than 5 cm past it.
constexpr double kMaxMedianDepthMetres = 50.0;
// The median is taken over about this many valid pixels: enough for a unit
// slip, which moves every pixel, and cheap at any resolution.
constexpr size_t kDepthMedianSamples = 4096;

std::string fixed1(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f", value);
  return text;
}

std::string general(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

struct PixelLayout {
  int cv_type = -1;  // -1: unsupported
  int bytes_per_pixel = 0;
  int bytes_per_channel = 1;
};

PixelLayout colourLayout(const std::string& encoding) {
  if (encoding == enc::BGR8 || encoding == enc::RGB8) return {CV_8UC3, 3};
  if (encoding == enc::BGRA8 || encoding == enc::RGBA8) return {CV_8UC4, 4};
  if (encoding == enc::MONO8) return {CV_8UC1, 1};
  return {};
}

PixelLayout depthLayout(const std::string& encoding) {
  if (encoding == enc::TYPE_16UC1 || encoding == enc::MONO16) return {CV_16UC1, 2, 2};
  if (encoding == enc::TYPE_32FC1) return {CV_32FC1, 4, 4};
  return {};
}

std::string size(uint32_t width, uint32_t height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

std::string checkBuffer(const sensor_msgs::Image& image, const PixelLayout& layout,
                        const std::string& what) {
  if (image.width == 0 || image.height == 0)
    return what + " image is empty (" + size(image.width, image.height) + ")";
  if (static_cast<uint64_t>(image.step) <
      static_cast<uint64_t>(image.width) * layout.bytes_per_pixel)
    return what + " image step " + std::to_string(image.step) + " is shorter than a row of " +
           std::to_string(image.width) + " '" + messageExcerpt(image.encoding) + "' pixels";
  const uint64_t needed = static_cast<uint64_t>(image.step) * image.height;
  if (static_cast<uint64_t>(image.data.size()) < needed)
    return what + " image holds " + std::to_string(image.data.size()) +
           " bytes, step x height needs " + std::to_string(needed);
  // sensor_msgs/Image: data is exactly step x height. More means the header
  // describes another image than the buffer holds (e.g. colour relabelled).
  if (static_cast<uint64_t>(image.data.size()) > needed)
    return what + " image holds " + std::to_string(image.data.size()) +
           " bytes, more than step x height (" + std::to_string(needed) + ") for '" +
           messageExcerpt(image.encoding) + "' " + size(image.width, image.height);
  // A colour buffer published as 16-bit depth (cv_bridge with the wrong
  // encoding keeps the colour step) reads as noise in metres. Row padding is
  // legal, but rows of exactly 3 or 4 bytes a pixel are a colour image's.
  if (layout.bytes_per_pixel == 2 && image.width > 0 &&
      (image.step == 3 * image.width || image.step == 4 * image.width))
    return what + " image is labelled '" + messageExcerpt(image.encoding) +
           "' (2 bytes a pixel) but its rows hold " + std::to_string(image.step / image.width) +
           " bytes a pixel (step " + std::to_string(image.step) + " for width " +
           std::to_string(image.width) + "): a colour image on the depth topic?";
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
  // Multi-byte depth in the other byte order would be read as garbage
  // distances, which is worse than no frame.
  constexpr bool host_big_endian = true;
#else
  constexpr bool host_big_endian = false;
#endif
  if (layout.bytes_per_channel > 1 && static_cast<bool>(image.is_bigendian) != host_big_endian)
    return what + " image byte order (is_bigendian=" + std::to_string(image.is_bigendian) +
           ") differs from this machine's";
  return {};
}

std::string checkColour(const sensor_msgs::Image& colour) {
  const PixelLayout layout = colourLayout(colour.encoding);
  if (layout.cv_type < 0)
    return "unsupported colour encoding '" + messageExcerpt(colour.encoding) +
           "' (expected bgr8, rgb8, bgra8, rgba8 or mono8)";
  return checkBuffer(colour, layout, "colour");
}

// P is what image_geometry::PinholeCameraModel projects with: the camera matrix
// of the rectified image, which for registered depth is the colour camera's.
// An all-zero P is a camera_info that only fills K (hand-written publishers).
bool usesProjectionMatrix(const sensor_msgs::CameraInfo& info) {
  return std::any_of(info.P.begin(), info.P.end(), [](double v) { return v != 0.0; });
}

// Why no depth pixel is usable, by kind of invalid value: "76800 zero",
// "38400 NaN, 38400 infinite", ... 16-bit depth: 0 (no reading) and 65535
// (saturated); float depth: zero, NaN, +-Inf and negative.
std::string describeInvalidDepth(const cv::Mat& raw) {
  uint64_t zero = 0, nan = 0, infinite = 0, negative = 0, saturated = 0;
  for (int v = 0; v < raw.rows; ++v) {
    if (raw.type() == CV_16UC1) {
      const auto* row = raw.ptr<uint16_t>(v);
      for (int u = 0; u < raw.cols; ++u) {
        zero += row[u] == 0;
        saturated += row[u] == 65535;
      }
    } else {
      const auto* row = raw.ptr<float>(v);
      for (int u = 0; u < raw.cols; ++u) {
        const float d = row[u];
        if (std::isnan(d))
          ++nan;
        else if (std::isinf(d))
          ++infinite;
        else if (d < 0)
          ++negative;
        else if (d == 0)
          ++zero;
      }
    }
  }
  std::string text;
  auto add = [&text](uint64_t count, const char* kind) {
    if (!count) return;
    text += (text.empty() ? "" : ", ") + std::to_string(count) + " " + kind;
  };
  add(zero, "zero");
  add(nan, "NaN");
  add(infinite, "infinite");
  add(negative, "negative");
  add(saturated, "65535 (saturated)");
  return text;
}

// Finite, positive intrinsics can still be nonsense that only shows up as "no
// pose hypothesis passed the rigidity checks"; the field of view names it.
std::string checkFieldOfView(const relocalizer::CameraIntrinsics& camera, const char* matrix) {
  auto degrees = [](double pixels, double focal) {
    return 2.0 * std::atan(0.5 * pixels / focal) * 180.0 / M_PI;
  };
  const struct {
    const char* direction;
    double fov;
    const char* focal_name;
    double focal;
    const char* size_name;
    int size;
  } axes[] = {
      {"horizontal", degrees(camera.width, camera.fx), "fx", camera.fx, "width", camera.width},
      {"vertical", degrees(camera.height, camera.fy), "fy", camera.fy, "height", camera.height}};
  for (const auto& axis : axes)
    if (!(axis.fov >= kMinFieldOfViewDeg && axis.fov <= kMaxFieldOfViewDeg))
      return std::string("camera_info ") + matrix + " gives a " + fixed1(axis.fov) + " deg " +
             axis.direction + " field of view (" + axis.focal_name + "=" + general(axis.focal) +
             " for " + axis.size_name + " " + std::to_string(axis.size) +
             "): an RGB-D camera sees " + general(kMinFieldOfViewDeg) + " to " +
             general(kMaxFieldOfViewDeg) + " deg; is " + matrix +
             " in pixels, for this image size?";
  return {};
}

// REP 118 float depth is metres; see kMaxMedianDepthMetres.
std::string checkMetres(const cv::Mat& metres) {
  const size_t pixels = metres.total();
  const size_t stride = std::max<size_t>(1, pixels / kDepthMedianSamples);
  std::vector<double> valid;
  valid.reserve(pixels / stride + 1);
  const cv::Mat continuous = metres.isContinuous() ? metres : metres.clone();
  const float* depth = continuous.ptr<float>();
  for (size_t i = 0; i < pixels; i += stride)
    if (std::isfinite(depth[i])) valid.push_back(depth[i]);
  if (valid.empty()) return {};  // too little depth is the core's call
  const double median = relocalizer::median(std::move(valid));
  if (median <= kMaxMedianDepthMetres) return {};
  return "32FC1 depth must be metres (REP 118): median valid depth " + fixed1(median) +
         " m, beyond any RGB-D sensor's range (" + general(kMaxMedianDepthMetres) +
         " m); millimetres?";
}

}  // namespace

std::string messageExcerpt(const std::string& text, size_t max_bytes) {
  return relocalizer::textExcerpt(text, max_bytes);
}

bool colourEncodingSupported(const std::string& encoding) {
  return colourLayout(encoding).cv_type >= 0;
}
bool depthEncodingSupported(const std::string& encoding) {
  return depthLayout(encoding).cv_type >= 0;
}

relocalizer::CameraIntrinsics cameraFromInfo(const sensor_msgs::CameraInfo& info) {
  relocalizer::CameraIntrinsics camera;
  if (usesProjectionMatrix(info)) {
    camera.fx = info.P[0];
    camera.fy = info.P[5];
    camera.cx = info.P[2];
    camera.cy = info.P[6];
  } else {
    camera.fx = info.K[0];
    camera.fy = info.K[4];
    camera.cx = info.K[2];
    camera.cy = info.K[5];
  }
  camera.width = static_cast<int>(info.width);
  camera.height = static_cast<int>(info.height);
  return camera;
}

const char* intrinsicsMatrixName(const sensor_msgs::CameraInfo& info) {
  return usesProjectionMatrix(info) ? "P" : "K";
}

std::string stripLeadingSlashes(const std::string& frame_id) {
  const size_t first = frame_id.find_first_not_of('/');
  return first == std::string::npos ? std::string() : frame_id.substr(first);
}

std::string checkFrameMessages(const sensor_msgs::Image& colour, const sensor_msgs::Image& depth,
                               const sensor_msgs::CameraInfo& info) {
  if (colourLayout(colour.encoding).cv_type < 0) return checkColour(colour);
  const PixelLayout depth_layout = depthLayout(depth.encoding);
  if (depth_layout.cv_type < 0)
    return "unsupported depth encoding '" + messageExcerpt(depth.encoding) +
           "' (expected 16UC1 millimetres or 32FC1 metres, REP 118)" +
           (colourLayout(depth.encoding).cv_type >= 0 ? "; a colour image on the depth topic?"
                                                      : "");
  if (std::string why = checkColour(colour); !why.empty()) return why;
  if (std::string why = checkBuffer(depth, depth_layout, "depth"); !why.empty()) return why;
  if (colour.width != depth.width || colour.height != depth.height)
    return "colour (" + size(colour.width, colour.height) + ") and depth (" +
           size(depth.width, depth.height) + ") differ in size; depth must be registered to colour";
  if (info.width != colour.width || info.height != colour.height)
    return "camera_info is for " + size(info.width, info.height) + " but the images are " +
           size(colour.width, colour.height);
  const std::string colour_frame = stripLeadingSlashes(colour.header.frame_id);
  const std::string depth_frame = stripLeadingSlashes(depth.header.frame_id);
  if (colour_frame != depth_frame)
    return "depth frame '" + messageExcerpt(depth_frame) + "' differs from colour frame '" +
           messageExcerpt(colour_frame) + "'; depth must be registered to colour";
  const relocalizer::CameraIntrinsics camera = cameraFromInfo(info);
  if (std::string why = camera.validationError(); !why.empty())
    return std::string("camera_info ") + intrinsicsMatrixName(info) + " is unusable: " + why;
  return checkFieldOfView(camera, intrinsicsMatrixName(info));
}

Expected<cv::Mat> colourToBgr8(const sensor_msgs::Image& colour) {
  if (std::string why = checkColour(colour); !why.empty()) return relocalizer::makeError(why);
  try {
    return cv_bridge::toCvCopy(colour, enc::BGR8)->image;
  } catch (const cv_bridge::Exception& e) {
    return relocalizer::makeError(
        "colour '" + messageExcerpt(colour.encoding) +
        "' cannot be converted to bgr8: " + messageExcerpt(e.what(), 256));
  }
}

Expected<RgbdFrame> frameFromMessages(const sensor_msgs::Image& colour,
                                      const sensor_msgs::Image& depth,
                                      const sensor_msgs::CameraInfo& info) {
  if (std::string why = checkFrameMessages(colour, depth, info); !why.empty())
    return relocalizer::makeError(why);
  RgbdFrame frame;
  auto bgr = colourToBgr8(colour);
  if (!bgr) return relocalizer::makeError(bgr.error());
  // The pixels in place (no copy): depthToMetres writes a new image anyway.
  cv::Mat raw_depth;
  try {
    raw_depth = cv_bridge::toCvShare(depth, nullptr)->image;
  } catch (const cv_bridge::Exception& e) {
    return relocalizer::makeError("depth '" + messageExcerpt(depth.encoding) +
                                  "' cannot be read: " + messageExcerpt(e.what(), 256));
  }
  // REP 118: 16-bit depth is millimetres.
  auto metres = relocalizer::depthToMetres(raw_depth, 1000.0);
  if (!metres) return relocalizer::makeError(metres.error());
  // The core would say "too little valid depth: 0 pixels"; which invalid
  // values the camera sent tells a broken driver from a covered lens.
  if (relocalizer::countValidDepth(*metres) == 0)
    return relocalizer::makeError("depth has no valid pixel: " + describeInvalidDepth(raw_depth));
  if (depth.encoding == enc::TYPE_32FC1)
    if (std::string why = checkMetres(*metres); !why.empty()) return relocalizer::makeError(why);
  frame.colour = std::move(*bgr);
  frame.depth = std::move(*metres);
  frame.camera = cameraFromInfo(info);
  frame.stamp = colour.header.stamp.toSec();
  frame.id = static_cast<int>(colour.header.seq);
  frame.source = "frame at " + std::to_string(colour.header.stamp.sec) + "." +
                 std::to_string(colour.header.stamp.nsec);
  if (std::string why = relocalizer::frameValidationError(frame); !why.empty())
    return relocalizer::makeError(why);
  return frame;
}

namespace {
// geometry_msgs' covariance layout.
using RowMajor6d = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;

// The pose with its rotation block projected onto the nearest rotation, so a
// quaternion taken from it is well defined even after drift in composition.
Pose orthonormalised(const Pose& pose) {
  Pose out = pose;
  out.linear() = relocalizer::nearestRotation(pose.linear());
  return out;
}
}  // namespace

geometry_msgs::Pose toPoseMsg(const Pose& pose) { return tf2::toMsg(orthonormalised(pose)); }

geometry_msgs::Transform toTransformMsg(const Pose& pose) {
  return tf2::eigenToTransform(orthonormalised(pose)).transform;
}

// Quaternions from messages are normalised (poseFromTranslationQuaternion):
// hand-written and recorded ones are often a little off unit length.
Pose fromTransformMsg(const geometry_msgs::Transform& transform) {
  Eigen::Vector3d translation;
  Eigen::Quaterniond rotation;
  tf2::fromMsg(transform.translation, translation);
  tf2::fromMsg(transform.rotation, rotation);
  return relocalizer::poseFromTranslationQuaternion(translation, rotation);
}

Pose fromPoseMsg(const geometry_msgs::Pose& pose) {
  Eigen::Vector3d position;
  Eigen::Quaterniond rotation;
  tf2::fromMsg(pose.position, position);
  tf2::fromMsg(pose.orientation, rotation);
  return relocalizer::poseFromTranslationQuaternion(position, rotation);
}

geometry_msgs::PoseWithCovariance toPoseWithCovarianceMsg(const Pose& pose,
                                                          const Matrix6d& covariance) {
  geometry_msgs::PoseWithCovariance msg;
  msg.pose = toPoseMsg(pose);
  Eigen::Map<RowMajor6d>(msg.covariance.data()) = covariance;
  return msg;
}

Matrix6d covarianceFromMsg(const geometry_msgs::PoseWithCovariance& msg) {
  return Eigen::Map<const RowMajor6d>(msg.covariance.data());
}

}  // namespace relocalizer_ros
