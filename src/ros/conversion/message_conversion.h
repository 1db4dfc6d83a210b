#pragma once
// sensor_msgs in, RgbdFrame out; core poses out as geometry_msgs. The only place
// where ROS message layouts meet core types, so the node class stays about
// threading and plumbing. Pixels go through cv_bridge and poses through
// tf2_eigen; what stays here is what they do not check.

#include <geometry_msgs/PoseWithCovariance.h>
#include <geometry_msgs/Transform.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <cstddef>
#include <opencv2/core.hpp>
#include <string>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"

namespace relocalizer_ros {

using relocalizer::Expected;
using relocalizer::Matrix6d;
using relocalizer::Pose;
using relocalizer::RgbdFrame;

// The intrinsics (fx, fy, cx, cy) and image size of a camera_info's images;
// not validated. From P, the camera matrix of rectified and registered images,
// as image_geometry::PinholeCameraModel reads it; from K when P is all zero
// (publishers that fill only K).
relocalizer::CameraIntrinsics cameraFromInfo(const sensor_msgs::CameraInfo& info);
// "P" or "K": the matrix cameraFromInfo reads, for messages about it.
const char* intrinsicsMatrixName(const sensor_msgs::CameraInfo& info);

// Text taken from a message (an encoding, a frame_id), or an exception text
// that repeats one, as it may be quoted in a reason or a log line: at most
// max_bytes of it followed by "... (N bytes)", control characters and bytes
// that are not UTF-8 as '?' (core/outside_text.h).
// Publishers decide how long these strings are; a 1 MB encoding must not
// become a 1 MB log line, nor a newline in a frame_id a second line.
constexpr size_t kMessageExcerptBytes = 64;
std::string messageExcerpt(const std::string& text, size_t max_bytes = kMessageExcerptBytes);

// tf2 rejects frame ids with a leading slash (a tf1 habit that bags and old
// drivers still carry), so every frame id the node reads or is given goes
// through this.
std::string stripLeadingSlashes(const std::string& frame_id);

// The image encodings frameFromMessages converts: colour bgr8, rgb8, bgra8,
// rgba8, mono8; depth 16UC1 or mono16 millimetres, 32FC1 metres (REP 118).
bool colourEncodingSupported(const std::string& encoding);
bool depthEncodingSupported(const std::string& encoding);

// Why the three messages cannot form a frame, or empty. Reads headers and sizes
// only (O(1)), so image callbacks can run it on every message and report bad
// input at once, while the pixel work waits until a frame is actually used.
// Checks: supported encodings (colour bgr8/rgb8/bgra8/rgba8/mono8, depth
// 16UC1/mono16 millimetres or 32FC1 metres, REP 118), buffer sizes equal to
// step x height, 16-bit depth whose rows hold 3 or 4 bytes a pixel (a colour
// image labelled as depth), equal colour/depth/camera_info sizes, usable
// intrinsics (finite, positive focal lengths in P, or K, giving a plausible
// field of view), and equal colour/depth frame ids (depth must be registered
// to colour). Strings from the messages are quoted through messageExcerpt.
std::string checkFrameMessages(const sensor_msgs::Image& colour, const sensor_msgs::Image& depth,
                               const sensor_msgs::CameraInfo& info);

// One colour message as 8-bit BGR (cv_bridge), after the checks above for
// colour alone: encodings bgr8, rgb8, bgra8, rgba8, mono8 and the buffer size.
Expected<cv::Mat> colourToBgr8(const sensor_msgs::Image& colour);

// The frame the core relocalizes: BGR8 colour, float metres depth, intrinsics
// from cameraFromInfo. Fails with checkFrameMessages' reason, a conversion
// error, or, when no depth pixel is valid, "depth has no valid pixel: " and
// what the pixels were ("76800 zero", "76800 NaN", "infinite", "negative", "65535 (saturated)"),
// or, when 32FC1 depth is implausibly far for metres, a reason that suggests
// millimetres.
Expected<RgbdFrame> frameFromMessages(const sensor_msgs::Image& colour,
                                      const sensor_msgs::Image& depth,
                                      const sensor_msgs::CameraInfo& info);

geometry_msgs::Pose toPoseMsg(const Pose& pose);
geometry_msgs::Transform toTransformMsg(const Pose& pose);
Pose fromTransformMsg(const geometry_msgs::Transform& transform);
Pose fromPoseMsg(const geometry_msgs::Pose& pose);

// The solver's covariance is already in geometry_msgs order (x y z, then
// rotations about the fixed world axes), so this only flattens it row-major.
geometry_msgs::PoseWithCovariance toPoseWithCovarianceMsg(const Pose& pose,
                                                          const Matrix6d& covariance);
// The other way: a message's row-major covariance as a matrix.
Matrix6d covarianceFromMsg(const geometry_msgs::PoseWithCovariance& msg);

}  // namespace relocalizer_ros
