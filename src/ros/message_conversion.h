#pragma once
// sensor_msgs in, RgbdFrame out; core poses out as geometry_msgs. The only place
// where ROS message layouts meet core types, so the node class stays about
// threading and plumbing.

#include <geometry_msgs/PoseWithCovariance.h>
#include <geometry_msgs/Transform.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <string>

#include "relocalizer/expected.h"
#include "relocalizer/frame.h"
#include "relocalizer/pose.h"
#include "relocalizer/pose_solver.h"

namespace relocalizer_ros {

using relocalizer::Expected;
using relocalizer::Matrix6d;
using relocalizer::Pose;
using relocalizer::RgbdFrame;

// tf2 rejects frame ids with a leading slash (a tf1 habit that bags and old
// drivers still carry), so every frame id the node reads or is given goes
// through this.
// K (fx, fy, cx, cy) and the image size of a camera_info; not validated.
relocalizer::CameraIntrinsics cameraFromInfo(const sensor_msgs::CameraInfo& info);

std::string stripLeadingSlashes(const std::string& frame_id);

// Why the three messages cannot form a frame, or empty. Reads headers and sizes
// only (O(1)), so image callbacks can run it on every message and report bad
// input at once, while the pixel work waits until a frame is actually used.
// Checks: supported encodings (colour bgr8/rgb8/bgra8/rgba8/mono8, depth
// 16UC1/mono16 millimetres or 32FC1 metres, REP 118), buffer sizes equal to
// step x height, 16-bit depth whose rows hold 3 or 4 bytes a pixel (a colour
// image labelled as depth), equal colour/depth/camera_info sizes, a usable K
// (finite, positive focal lengths), and equal colour/depth frame ids (depth
// must be registered to colour).
std::string checkFrameMessages(const sensor_msgs::Image& colour, const sensor_msgs::Image& depth,
                               const sensor_msgs::CameraInfo& info);

// The frame the core relocalizes: BGR8 colour, float metres depth, intrinsics
// from K. Fails with checkFrameMessages' reason, a conversion error, or, when
// no depth pixel is valid, "depth has no valid pixel: " and what the pixels
// were ("76800 zero", "76800 NaN", "infinite", "negative", "65535 (saturated)").
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

}  // namespace relocalizer_ros
