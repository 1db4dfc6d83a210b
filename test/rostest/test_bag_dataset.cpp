// Rosbags as datasets (src/ros/bag/bag_dataset.h), without a ROS master: bags are
// written here with the rosbag API. Covers frame association, the two pose
// sources, key frames, the bad bags' errors, and `train --bag` against
// `train --dataset` on the same frames (same frames kept, same model bytes).

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>

#include "../../src/ros/bag/bag_dataset.h"
#include "../../src/ros/conversion/message_conversion.h"
#include "../unit/support.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/id_ranges.h"
#include "relocalizer/core/key_frame_rule.h"
#include "relocalizer/data/dataset.h"
#include "relocalizer/data/frame_selection.h"
#include "relocalizer/data/tum_trajectory.h"
#include "relocalizer/forest/model_io.h"

using namespace relocalizer_ros;
using relocalizer::testing::TempDir;
namespace enc = sensor_msgs::image_encodings;

namespace {

const std::string kRgb = "/camera/rgb/image_raw";
const std::string kDepth = "/camera/depth/image_raw";
const std::string kInfo = "/camera/rgb/camera_info";
const std::string kCameraFrame = "camera_rgb_optical_frame";

// ---- writing bags as make_bag and a SLAM recording would -------------------------

sensor_msgs::Image imageMsg(const cv::Mat& mat, const std::string& encoding, const ros::Time& stamp,
                            const std::string& frame_id = kCameraFrame) {
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = frame_id;
  return *cv_bridge::CvImage(header, encoding, mat).toImageMsg();
}

sensor_msgs::CameraInfo infoMsg(const relocalizer::CameraIntrinsics& k, const ros::Time& stamp) {
  sensor_msgs::CameraInfo info;
  info.header.stamp = stamp;
  info.header.frame_id = kCameraFrame;
  info.width = static_cast<uint32_t>(k.width);
  info.height = static_cast<uint32_t>(k.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  info.K = {k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {k.fx, 0, k.cx, 0, 0, k.fy, k.cy, 0, 0, 0, 1, 0};
  return info;
}

geometry_msgs::TransformStamped transformMsg(const std::string& parent, const std::string& child,
                                             const ros::Time& stamp, const Pose& parent_T_child) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform = toTransformMsg(parent_T_child);
  return t;
}

void writeTf(rosbag::Bag& bag, const std::vector<geometry_msgs::TransformStamped>& transforms,
             bool is_static = false) {
  tf2_msgs::TFMessage msg;
  msg.transforms = transforms;
  bag.write(is_static ? "/tf_static" : "/tf", transforms.front().header.stamp, msg);
}

// One small frame: 8x6 pixels, plain colour, depth 1.5 m.
struct TinyFrame {
  cv::Mat colour = cv::Mat(6, 8, CV_8UC3, cv::Scalar(10, 20, 30));
  cv::Mat depth = cv::Mat(6, 8, CV_16UC1, cv::Scalar(1500));
  relocalizer::CameraIntrinsics camera{10, 10, 4, 3, 8, 6};
};

void writeTinyFrame(rosbag::Bag& bag, const ros::Time& stamp, bool with_depth = true,
                    const std::string& colour_encoding = enc::BGR8,
                    const std::string& depth_encoding = enc::TYPE_16UC1) {
  TinyFrame f;
  bag.write(kInfo, stamp, infoMsg(f.camera, stamp));
  if (with_depth) bag.write(kDepth, stamp, imageMsg(f.depth, depth_encoding, stamp));
  bag.write(kRgb, stamp, imageMsg(f.colour, colour_encoding, stamp));
}

Pose poseAt(double x, double yaw_degrees = 0.0) {
  Pose p = Pose::Identity();
  p.translation() = Eigen::Vector3d(x, 0.5, 1.2);
  p.linear() =
      Eigen::AngleAxisd(yaw_degrees * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

ros::Time at(double seconds) { return ros::Time(seconds); }

std::string openError(const std::string& path, const BagOptions& options = {}) {
  auto opened = BagDataset::open(path, options);
  if (opened) return "(opened)";
  return opened.error();
}

// Runs a tool; returns its exit status and fills `output` with stdout + stderr.
int runTool(const std::string& arguments, std::string* output = nullptr) {
  const std::string command = std::string(RELOCALIZER_TOOL_DIR) + "/" + arguments + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return -1;
  std::string text;
  char buffer[4096];
  while (size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) text.append(buffer, n);
  const int status = pclose(pipe);
  if (output) *output = text;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

// ---- association, pose sources, selection --------------------------------------

TEST(BagDataset, AssociatesByNearestStampAndNumbersFramesInThatOrder) {
  TempDir dir("bag_sync");
  const std::string path = dir.str() + "/sync.bag";
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    TinyFrame f;
    for (int i = 0; i < 6; ++i) {
      const ros::Time t = at(10.0 + i / 30.0);
      bag.write(kRgb, t, imageMsg(f.colour, enc::RGB8, t));
      // Depth 5 ms late, as an unsynchronised Kinect; none for frame 3.
      if (i != 3)
        bag.write(kDepth, t, imageMsg(f.depth, enc::TYPE_16UC1, t + ros::Duration(0.005)));
      if (i == 0) bag.write(kInfo, t, infoMsg(f.camera, t));  // one camera_info for the first only
      if (i >= 1) bag.write(kInfo, t, infoMsg(f.camera, t + ros::Duration(0.001)));
      bag.write("/ground_truth/pose", t, [&] {
        geometry_msgs::PoseStamped p;
        p.header.stamp = t;
        p.header.frame_id = "map";
        p.pose = toPoseMsg(poseAt(0.1 * i));
        return p;
      }());
    }
  }
  BagOptions options;
  options.pose_topic = "/ground_truth/pose";
  auto opened = BagDataset::open(path, options);
  ASSERT_TRUE(opened.ok()) << opened.error();
  const BagDataset& bag = **opened;
  EXPECT_EQ(bag.counts().colour_images, 6);
  EXPECT_EQ(bag.counts().synchronized, 5);
  EXPECT_EQ(bag.counts().colour_without_depth, 1);
  ASSERT_EQ(bag.size(), 5u);
  // Ids are indices among synchronized frames: the colour image without depth has none.
  for (size_t i = 0; i < bag.size(); ++i) EXPECT_EQ(bag.id(i), static_cast<int>(i));
  EXPECT_NEAR(bag.stamp(3), 10.0 + 4 / 30.0, 1e-6);  // bag frame 3 is colour image 4
  EXPECT_NEAR(bag.groundTruth(3)->translation().x(), 0.4, 1e-12);

  auto frame = bag.load(3);
  ASSERT_TRUE(frame.ok()) << frame.error();
  EXPECT_EQ(frame->id, 3);
  EXPECT_EQ(frame->colour.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));  // rgb8 -> BGR
  EXPECT_FLOAT_EQ(frame->depth.at<float>(2, 2), 1.5f);
  EXPECT_EQ(frame->camera.fx, 10.0);
  ASSERT_TRUE(frame->ground_truth);
  EXPECT_TRUE(frame->ground_truth->isApprox(*bag.groundTruth(3)));
  EXPECT_NE(bag.summary().find("1 colour images without depth"), std::string::npos)
      << bag.summary();

  // Tighter than the depth delay: nothing is left, and the message says which topics.
  options.sync_tolerance = 0.002;
  const std::string error = openError(path, options);
  EXPECT_NE(error.find("no colour image on '/camera/rgb/image_raw' has a depth image on "
                       "'/camera/depth/image_raw'"),
            std::string::npos)
      << error;
}

TEST(BagDataset, InterpolatesTfChainsAndSkipsFramesInTrackingGaps) {
  TempDir dir("bag_tf");
  const std::string path = dir.str() + "/tf.bag";
  // map -> odom at 10 Hz (slowly drifting), odom -> camera at 10 Hz with a gap
  // from 2.0 to 2.5 s (tracking lost), images at 30 Hz from 1.0 to 3.0 s.
  const auto map_T_odom = [](double t) { return poseAt(0.01 * t); };
  const auto odom_T_camera = [](double t) { return poseAt(0.5 * t, 10.0 * t); };
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    for (int k = 0; k <= 40; ++k) {
      const double t = 0.9 + 0.1 * k;
      writeTf(bag, {transformMsg("/map", "odom", at(t), map_T_odom(t))});  // tf1-style slash
      if (t < 1.95 || t > 2.55)
        writeTf(bag, {transformMsg("odom", kCameraFrame, at(t), odom_T_camera(t))});
    }
    for (int i = 0; i <= 60; ++i) writeTinyFrame(bag, at(1.0 + i / 30.0));
  }
  auto opened = BagDataset::open(path);
  ASSERT_TRUE(opened.ok()) << opened.error();
  const BagDataset& bag = **opened;
  EXPECT_EQ(bag.poseSource(), "TF map -> " + kCameraFrame);
  EXPECT_EQ(bag.counts().synchronized, 61);
  // Samples at 1.9 and 2.6 s: frames whose stamp is within 0.1 s of both have a pose.
  int expected_without = 0;
  for (int i = 0; i <= 60; ++i) {
    const double t = 1.0 + i / 30.0;
    if (t > 1.9 + 1e-9 && t < 2.6 - 1e-9 && (t - 1.9 > 0.1 + 1e-9 || 2.6 - t > 0.1 + 1e-9))
      ++expected_without;
  }
  EXPECT_EQ(bag.counts().without_pose, expected_without);
  EXPECT_EQ(static_cast<int>(bag.size()), 61 - expected_without);
  for (size_t i = 0; i < bag.size(); ++i) {
    const double t = bag.stamp(i);
    // Linear motion and constant yaw rate: interpolation is exact up to round-off.
    const Pose truth = map_T_odom(t) * odom_T_camera(t);
    EXPECT_LT(relocalizer::translationError(*bag.groundTruth(i), truth), 1e-6)
        << "frame " << bag.id(i);
    EXPECT_LT(relocalizer::rotationErrorDegrees(*bag.groundTruth(i), truth), 1e-5)
        << "frame " << bag.id(i);
  }
  const std::string summary = bag.summary();
  EXPECT_NE(summary.find(std::to_string(expected_without) + " skipped without a pose in time"),
            std::string::npos)
      << summary;

  // Key frames: 0.5 m/s and 10 deg/s; every 0.1 m or 3 deg since the last kept frame.
  BagOptions keys;
  keys.min_translation = 0.1;
  keys.min_rotation_degrees = 3.0;
  auto selected = BagDataset::open(path, keys);
  ASSERT_TRUE(selected.ok()) << selected.error();
  EXPECT_LT((*selected)->size(), bag.size() / 4);
  for (size_t i = 1; i < (*selected)->size(); ++i) {
    const Pose& a = *(*selected)->groundTruth(i - 1);
    const Pose& b = *(*selected)->groundTruth(i);
    EXPECT_TRUE(relocalizer::translationError(a, b) >= 0.1 - 1e-12 ||
                relocalizer::rotationErrorDegrees(a, b) >= 3.0 - 1e-9);
  }
  // --frames picks by id before key frames.
  BagOptions some;
  some.frames = "0-9";
  auto first_ten = BagDataset::open(path, some);
  ASSERT_TRUE(first_ten.ok()) << first_ten.error();
  EXPECT_EQ((*first_ten)->size(), 10u);
}

TEST(BagDataset, PoseTopicsInterpolateAndMustBeInTheMapAndCameraFrames) {
  TempDir dir("bag_pose_topic");
  const std::string path = dir.str() + "/odom.bag";
  const auto write = [&](const std::string& frame, const std::string& child) {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    for (int k = 0; k < 5; ++k) {
      nav_msgs::Odometry o;
      o.header.stamp = at(1.0 + 0.1 * k);
      o.header.frame_id = frame;
      o.child_frame_id = child;
      o.pose.pose = toPoseMsg(poseAt(k * 0.1, 2.0 * k));
      bag.write("/slam/odom", o.header.stamp, o);
    }
    for (int i = 0; i < 10; ++i) writeTinyFrame(bag, at(1.0 + i / 30.0));
  };
  write("map", kCameraFrame);
  BagOptions options;
  options.pose_topic = "slam/odom";  // without the slash, as people type it
  auto opened = BagDataset::open(path, options);
  ASSERT_TRUE(opened.ok()) << opened.error();
  ASSERT_EQ((*opened)->size(), 10u);
  EXPECT_EQ((*opened)->poseSource(), "topic /slam/odom (nav_msgs/Odometry)");
  const Pose p = *(*opened)->groundTruth(1);  // 1/3 of the way from sample 0 to 1
  EXPECT_NEAR(p.translation().x(), 0.1 / 3.0, 1e-9);
  EXPECT_NEAR(relocalizer::rotationErrorDegrees(p, poseAt(0, 2.0 / 3.0)), 0.0, 1e-6);

  write("odom", kCameraFrame);
  std::string error = openError(path, options);
  EXPECT_NE(error.find("poses on '/slam/odom' are in frame 'odom', not the map frame 'map'"),
            std::string::npos)
      << error;
  options.map_frame = "odom";
  EXPECT_EQ(openError(path, options), "(opened)");

  write("map", "base_link");
  options.map_frame = "map";
  error = openError(path, options);
  EXPECT_NE(error.find("are of frame 'base_link', not the camera frame '" + kCameraFrame + "'"),
            std::string::npos)
      << error;
}

// ---- bad bags --------------------------------------------------------------------

TEST(BagDataset, BadBagsSayWhichTopicOrFrame) {
  TempDir dir("bad_bags");
  const auto bag_path = [&](const std::string& name) { return dir.str() + "/" + name + ".bag"; };
  const auto good_tf = [](rosbag::Bag& bag) {
    writeTf(bag, {transformMsg("map", kCameraFrame, at(1.0), poseAt(0))});
    writeTf(bag, {transformMsg("map", kCameraFrame, at(2.0), poseAt(1))});
  };

  // Missing topic: the message names it and lists what the bag has.
  {
    rosbag::Bag bag(bag_path("no_colour"), rosbag::bagmode::Write);
    TinyFrame f;
    bag.write(kDepth, at(1.5), imageMsg(f.depth, enc::TYPE_16UC1, at(1.5)));
    bag.write(kInfo, at(1.5), infoMsg(f.camera, at(1.5)));
    good_tf(bag);
  }
  std::string error = openError(bag_path("no_colour"));
  EXPECT_NE(error.find("no messages on topic '/camera/rgb/image_raw' (--rgb-topic)"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("/camera/depth/image_raw (sensor_msgs/Image, 1 message)"), std::string::npos)
      << error;
  EXPECT_NE(error.find("/tf (tf2_msgs/TFMessage, 2 messages)"), std::string::npos) << error;

  // A topic of the wrong type.
  {
    rosbag::Bag bag(bag_path("wrong_type"), rosbag::bagmode::Write);
    TinyFrame f;
    bag.write(kRgb, at(1.5), infoMsg(f.camera, at(1.5)));
    bag.write(kDepth, at(1.5), imageMsg(f.depth, enc::TYPE_16UC1, at(1.5)));
    bag.write(kInfo, at(1.5), infoMsg(f.camera, at(1.5)));
    good_tf(bag);
  }
  error = openError(bag_path("wrong_type"));
  EXPECT_NE(
      error.find("topic '/camera/rgb/image_raw' (--rgb-topic) carries sensor_msgs/CameraInfo, "
                 "expected sensor_msgs/Image"),
      std::string::npos)
      << error;

  // No TF path between the frames: both named, with the frames the bag has.
  {
    rosbag::Bag bag(bag_path("no_path"), rosbag::bagmode::Write);
    writeTf(bag, {transformMsg("map", "odom", at(1.0), poseAt(0))});
    writeTf(bag, {transformMsg("camera_link", kCameraFrame, at(1.0), poseAt(0))}, true);
    writeTinyFrame(bag, at(1.5));
  }
  error = openError(bag_path("no_path"));
  EXPECT_NE(error.find("no TF path from the map frame 'map' (--map-frame) to the camera frame '" +
                       kCameraFrame + "'"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("camera_link (root)"), std::string::npos) << error;
  EXPECT_NE(error.find("odom (child of map)"), std::string::npos) << error;
  BagOptions renamed;
  renamed.depth_topic = "/camera/depth_registered/image_raw";
  error = openError(bag_path("no_path"), renamed);
  EXPECT_NE(error.find("no messages on topic '/camera/depth_registered/image_raw' (--depth-topic)"),
            std::string::npos)
      << error;
  BagOptions world;
  world.map_frame = "world";
  error = openError(bag_path("no_path"), world);
  EXPECT_NE(error.find("'world' is not in /tf or /tf_static"), std::string::npos) << error;

  // No TF at all.
  {
    rosbag::Bag bag(bag_path("no_tf"), rosbag::bagmode::Write);
    writeTinyFrame(bag, at(1.5));
  }
  error = openError(bag_path("no_tf"));
  EXPECT_NE(error.find("no poses: the bag has no /tf or /tf_static"), std::string::npos) << error;

  // Unsupported encodings: topic and encoding named.
  {
    rosbag::Bag bag(bag_path("yuv"), rosbag::bagmode::Write);
    writeTinyFrame(bag, at(1.5), true, "yuv422");
    good_tf(bag);
  }
  error = openError(bag_path("yuv"));
  EXPECT_NE(
      error.find(
          "topic '/camera/rgb/image_raw' (--rgb-topic): unsupported colour encoding 'yuv422'"),
      std::string::npos)
      << error;
  {
    rosbag::Bag bag(bag_path("depth8"), rosbag::bagmode::Write);
    writeTinyFrame(bag, at(1.5), true, enc::BGR8, enc::TYPE_8UC1);
    good_tf(bag);
  }
  error = openError(bag_path("depth8"));
  EXPECT_NE(
      error.find(
          "topic '/camera/depth/image_raw' (--depth-topic): unsupported depth encoding '8UC1'"),
      std::string::npos)
      << error;

  // Depth not registered to colour.
  {
    rosbag::Bag bag(bag_path("unregistered"), rosbag::bagmode::Write);
    TinyFrame f;
    bag.write(kRgb, at(1.5), imageMsg(f.colour, enc::BGR8, at(1.5)));
    bag.write(kDepth, at(1.5),
              imageMsg(f.depth, enc::TYPE_16UC1, at(1.5), "camera_depth_optical_frame"));
    bag.write(kInfo, at(1.5), infoMsg(f.camera, at(1.5)));
    good_tf(bag);
  }
  error = openError(bag_path("unregistered"));
  EXPECT_NE(
      error.find("depth on '/camera/depth/image_raw' is in frame 'camera_depth_optical_frame' but "
                 "colour on '/camera/rgb/image_raw' is in frame '" +
                 kCameraFrame + "'"),
      std::string::npos)
      << error;

  // An empty bag, a file that is no bag, no file.
  rosbag::Bag(bag_path("empty"), rosbag::bagmode::Write).close();
  error = openError(bag_path("empty"));
  EXPECT_NE(error.find("empty.bag: the bag is empty"), std::string::npos) << error;
  std::ofstream(bag_path("text")) << "not a bag\n";
  error = openError(bag_path("text"));
  EXPECT_NE(error.find("text.bag: cannot be opened as a rosbag"), std::string::npos) << error;
  error = openError(bag_path("missing"));
  EXPECT_NE(error.find("missing.bag: no such file"), std::string::npos) << error;

  // A recording cut short (no index at its end): the cure is named.
  {
    rosbag::Bag bag(bag_path("whole"), rosbag::bagmode::Write);
    writeTinyFrame(bag, at(1.5));
    good_tf(bag);
  }
  {
    std::ifstream in(bag_path("whole"), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_GT(bytes.size(), 200u);
    std::ofstream(bag_path("truncated"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  error = openError(bag_path("truncated"));
  EXPECT_NE(error.find("truncated.bag: cannot be opened as a rosbag: "), std::string::npos)
      << error;
  EXPECT_NE(error.find("`rosbag reindex`"), std::string::npos) << error;

  // Poses that never cover the images: the spans say why.
  {
    rosbag::Bag bag(bag_path("late_tf"), rosbag::bagmode::Write);
    writeTinyFrame(bag, at(1.5));
    writeTf(bag, {transformMsg("map", kCameraFrame, at(5.0), poseAt(0))});
    writeTf(bag, {transformMsg("map", kCameraFrame, at(6.0), poseAt(0))});
  }
  error = openError(bag_path("late_tf"));
  EXPECT_NE(error.find("none of the 1 selected frames"), std::string::npos) << error;
  EXPECT_NE(error.find("pose samples span 5.000000 - 6.000000"), std::string::npos) << error;

  // The tools print the same reason on one line and exit with 2.
  std::string output;
  EXPECT_EQ(
      runTool("train --bag " + bag_path("no_path") + " --output " + dir.str() + "/m.bin", &output),
      2);
  EXPECT_NE(output.find("train: error: "), std::string::npos) << output;
  EXPECT_NE(output.find("no TF path from the map frame 'map'"), std::string::npos) << output;
  EXPECT_EQ(std::count(output.begin(), output.end(), '\n'), 1) << output;
  EXPECT_EQ(runTool("evaluate --model x --bag " + bag_path("empty"), &output), 2);
  EXPECT_NE(output.find("the bag is empty"), std::string::npos) << output;
  EXPECT_EQ(runTool("train --dataset " + dir.str() + " --map-frame map --output x", &output), 2);
  EXPECT_NE(output.find("--map-frame requires --bag"), std::string::npos) << output;
  EXPECT_EQ(runTool("train --output x", &output), 2);
  EXPECT_NE(output.find("one of --dataset or --bag is required"), std::string::npos) << output;
}

TEST(BagDataset, MinMotionParses) {
  using relocalizer::parseMinMotion;
  auto both = parseMinMotion("0.05,5");
  ASSERT_TRUE(both.ok());
  EXPECT_EQ(both->metres, 0.05);
  EXPECT_EQ(both->degrees, 5.0);
  ASSERT_TRUE(parseMinMotion("0.1").ok());
  EXPECT_EQ(parseMinMotion("0.1")->degrees, 0.0);
  for (const char* bad : {"", "a,5", "0.05,", "-1,5", "1,2,3", "0.05;5", "nan,1"})
    EXPECT_FALSE(parseMinMotion(bad).ok()) << bad;
}

// ---- train --bag == train --dataset on the same frames --------------------------

namespace {

// The synthetic train folder as a SLAM recording: make_bag's topics and
// encodings, and the camera pose as a TF chain map -> odom -> base_link ->
// camera_rgb_optical_frame: map -> odom is a slowly drifting correction at
// 10 Hz (interpolated at the image stamps), odom -> base_link the odometry at
// every image, base_link -> camera static. Odometry is missing around
// `lost` (a tracking loss).
void writeSlamBag(const relocalizer::Dataset& data, const std::string& path,
                  const std::function<bool(int)>& lost) {
  Pose base_T_camera = Pose::Identity();  // REP 103 body to optical: z forward, x right, y down
  base_T_camera.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  base_T_camera.translation() = Eigen::Vector3d(0.05, -0.02, 0.3);
  const auto map_T_odom = [](double t) {
    Pose p = Pose::Identity();
    p.translation() = Eigen::Vector3d(0.3 + 0.01 * t, -0.2, 0.0);
    p.linear() = Eigen::AngleAxisd(0.4 + 0.002 * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return p;
  };
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  bag.setCompression(rosbag::compression::LZ4);
  const double start = 1.0, rate = 30.0;
  const double end = start + (data.size() - 1) / rate;
  writeTf(bag, {transformMsg("base_link", kCameraFrame, at(start), base_T_camera)}, true);
  for (double t = start - 0.05; t < end + 0.1; t += 0.1)
    writeTf(bag, {transformMsg("map", "odom", at(t), map_T_odom(at(t).toSec()))});
  for (size_t i = 0; i < data.size(); ++i) {
    auto frame = data.load(i);
    ASSERT_TRUE(frame.ok()) << frame.error();
    const ros::Time t = at(start + data.id(i) / rate);
    // What tf2 interpolates for map -> odom at t: linear in time here, so exact.
    const Pose odom_T_base =
        map_T_odom(t.toSec()).inverse() * *frame->ground_truth * base_T_camera.inverse();
    if (!lost(data.id(i))) writeTf(bag, {transformMsg("odom", "base_link", t, odom_T_base)});
    bag.write(kInfo, t, infoMsg(frame->camera, t));
    bag.write(kDepth, t,
              imageMsg(relocalizer::depthToMillimetres(frame->depth), enc::TYPE_16UC1, t));
    bag.write(kRgb, t, imageMsg(frame->colour, enc::BGR8, t));
  }
}

// The forests and parameters of a model file, without the training summary
// (paths, wall time and the like differ between any two runs).
std::vector<uint8_t> forestBytes(const std::string& path,
                                 relocalizer::TrainingSummary* summary = nullptr) {
  auto model = relocalizer::loadModel(path);
  EXPECT_TRUE(model.ok()) << model.error();
  if (!model) return {};
  if (summary) *summary = model->summary;
  model->summary = relocalizer::TrainingSummary{};
  return relocalizer::serializeModel(*model);
}

}  // namespace

TEST(BagTraining, TrainingFromASlamBagEqualsTrainingFromTheFolderOnTheSameFrames) {
  TempDir dir("bag_training");
  const std::string d = dir.str();
  ASSERT_EQ(runTool("synthesize --output " + d +
                    "/scene --seed 3 --train-frames 48 --test-frames 8 "
                    "--width 320 --height 240"),
            0);
  auto opened = relocalizer::openDataset(d + "/scene/train");
  ASSERT_TRUE(opened.ok()) << opened.error();
  const relocalizer::Dataset& data = **opened;
  const auto lost = [](int id) { return id >= 20 && id <= 25; };
  writeSlamBag(data, d + "/slam.bag", lost);
  if (HasFatalFailure()) return;

  // The frames the bag must keep, from the folder's ground truth: everything
  // but the tracking loss, thinned to key frames 5 cm / 5 degrees apart.
  std::vector<int> expected;
  const Pose* last = nullptr;
  for (size_t i = 0; i < data.size(); ++i) {
    if (lost(data.id(i))) continue;
    const Pose& pose = *data.groundTruth(i);
    if (last && relocalizer::translationError(pose, *last) < 0.05 &&
        relocalizer::rotationErrorDegrees(pose, *last) < 5.0)
      continue;
    expected.push_back(data.id(i));
    last = &pose;
  }
  ASSERT_GT(expected.size(), 8u);
  ASSERT_LT(expected.size(), data.size() - 6);

  BagOptions options;
  options.min_translation = 0.05;
  options.min_rotation_degrees = 5.0;
  auto bag = BagDataset::open(d + "/slam.bag", options);
  ASSERT_TRUE(bag.ok()) << bag.error();
  std::vector<int> kept;
  for (size_t i = 0; i < (*bag)->size(); ++i) kept.push_back((*bag)->id(i));
  EXPECT_EQ(kept, expected);
  EXPECT_EQ((*bag)->counts().without_pose, 6);
  // The TF chain gives back the folder's poses to round-off, and training sees
  // poses as float (training.cpp casts them), where that round-off vanishes.
  double max_metres = 0, max_degrees = 0;
  for (size_t i = 0; i < (*bag)->size(); ++i) {
    const Pose& from_bag = *(*bag)->groundTruth(i);
    const Pose& from_folder = *data.groundTruth(static_cast<size_t>((*bag)->id(i)));
    max_metres = std::max(max_metres, relocalizer::translationError(from_bag, from_folder));
    max_degrees = std::max(max_degrees, relocalizer::rotationErrorDegrees(from_bag, from_folder));
    EXPECT_TRUE(from_bag.cast<float>().matrix() == from_folder.cast<float>().matrix())
        << "frame " << (*bag)->id(i) << ": the poses differ after the cast to float";
  }
  std::printf("TF chain vs folder poses: at most %.2g m, %.2g deg apart\n", max_metres,
              max_degrees);
  EXPECT_LT(max_metres, 1e-12);
  EXPECT_LT(max_degrees, 1e-10);
  // Same pixels.
  for (size_t i : {size_t{0}, (*bag)->size() - 1}) {
    auto a = (*bag)->load(i);
    auto b = data.load(static_cast<size_t>((*bag)->id(i)));
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(cv::norm(a->colour, b->colour, cv::NORM_INF), 0.0);
    EXPECT_TRUE(cv::norm(a->depth == b->depth, cv::NORM_L1) ==
                cv::norm(cv::Mat(a->depth == a->depth), cv::NORM_L1));  // equal where not NaN
    EXPECT_EQ(cv::countNonZero(a->depth != a->depth), cv::countNonZero(b->depth != b->depth));
    EXPECT_EQ(a->camera.fx, b->camera.fx);
    EXPECT_EQ(a->camera.cx, b->camera.cx);
  }

  const std::string config =
      std::string(RELOCALIZER_SOURCE_DIR) + "/test/rostest/fixture_forest.yaml";
  std::string output;
  ASSERT_EQ(runTool("train --bag " + d + "/slam.bag --min-motion 0.05,5 --config " + config +
                        " --seed 11 --threads 2 --output " + d + "/bag.model",
                    &output),
            0)
      << output;
  EXPECT_NE(output.find("6 skipped without a pose in time"), std::string::npos) << output;
  const std::string ids = relocalizer::formatIdRanges(expected);
  ASSERT_EQ(runTool("train --dataset " + d + "/scene/train --frames " + ids + " --config " +
                        config + " --seed 11 --threads 1 --output " + d + "/folder.model",
                    &output),
            0)
      << output;

  relocalizer::TrainingSummary from_bag, from_folder;
  const auto bag_bytes = forestBytes(d + "/bag.model", &from_bag);
  const auto folder_bytes = forestBytes(d + "/folder.model", &from_folder);
  EXPECT_EQ(from_bag.images, static_cast<int>(expected.size()));
  EXPECT_EQ(from_folder.images, static_cast<int>(expected.size()));
  EXPECT_EQ(from_bag.frames, ids);
  EXPECT_EQ(from_bag.format, "rosbag (TF map -> " + kCameraFrame + ")");
  ASSERT_FALSE(bag_bytes.empty());
  EXPECT_TRUE(bag_bytes == folder_bytes)
      << "the models differ (" << bag_bytes.size() << " and " << folder_bytes.size() << " bytes)";

  // evaluate --bag on make_bag's own bag of the test frames, ground truth from
  // its pose topic, answers exactly as evaluate --dataset on the folder.
  ASSERT_EQ(runTool("make_bag --dataset " + d + "/scene/test --output " + d + "/test.bag", &output),
            0)
      << output;
  ASSERT_EQ(runTool("evaluate --model " + d + "/bag.model --bag " + d +
                        "/test.bag --pose-topic "
                        "/ground_truth/pose --threads 1 --output " +
                        d + "/eval_bag",
                    &output),
            0)
      << output;
  ASSERT_EQ(runTool("evaluate --model " + d + "/bag.model --dataset " + d +
                        "/scene/test --threads 1 "
                        "--output " +
                        d + "/eval_folder",
                    &output),
            0)
      << output;
  const auto poses = [](const std::string& file) {
    std::ifstream in(file);
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);)
      if (!line.empty() && line[0] != '#')
        lines.push_back(line.substr(line.find(' ')));  // drop the stamp
    return lines;
  };
  const auto bag_poses = poses(d + "/eval_bag/poses.txt");
  EXPECT_FALSE(bag_poses.empty());
  EXPECT_EQ(bag_poses, poses(d + "/eval_folder/poses.txt"));
}

// Every tool that reads posed frames takes --bag: benchmark and threshold_curves
// on make_bag's bag answer as on the folder it was written from.
TEST(BagTools, BenchmarkAndThresholdCurvesReadMakeBagsBag) {
  TempDir dir("bag_tools");
  const std::string d = dir.str();
  std::string output;
  ASSERT_EQ(
      runTool("synthesize --output " + d +
                  "/scene --seed 3 --train-frames 32 --test-frames 8 --width 320 --height 240",
              &output),
      0)
      << output;
  const std::string config =
      std::string(RELOCALIZER_SOURCE_DIR) + "/test/rostest/fixture_forest.yaml";
  ASSERT_EQ(runTool("train --dataset " + d + "/scene/train --config " + config +
                        " --threads 1 --output " + d + "/room.model",
                    &output),
            0)
      << output;
  ASSERT_EQ(runTool("make_bag --dataset " + d + "/scene/test --output " + d + "/test.bag", &output),
            0)
      << output;
  const std::string bag = "--bag " + d + "/test.bag --pose-topic /ground_truth/pose";
  const auto json = [](const std::string& file) {
    std::ifstream in(file);
    return nlohmann::json::parse(in, nullptr, false);
  };

  ASSERT_EQ(runTool("benchmark --model " + d + "/room.model " + bag + " --threads 1 --json " + d +
                        "/bench_bag.json",
                    &output),
            0)
      << output;
  ASSERT_EQ(runTool("benchmark --model " + d + "/room.model --dataset " + d +
                        "/scene/test --threads 1 --json " + d + "/bench_folder.json",
                    &output),
            0)
      << output;
  const auto bench_bag = json(d + "/bench_bag.json"), bench_folder = json(d + "/bench_folder.json");
  EXPECT_EQ(bench_bag["frames"], 8);
  EXPECT_EQ(bench_bag["frames"], bench_folder["frames"]);
  EXPECT_EQ(bench_bag["threads"]["1"]["within_5cm_5deg"],
            bench_folder["threads"]["1"]["within_5cm_5deg"]);

  const std::string outside = " --out-of-scene " + d + "/scene/train --threads 1";
  ASSERT_EQ(runTool("threshold_curves --model " + d + "/room.model " + bag + outside +
                        " --output " + d + "/curves_bag",
                    &output),
            0)
      << output;
  ASSERT_EQ(runTool("threshold_curves --model " + d + "/room.model --in-scene " + d +
                        "/scene/test" + outside + " --output " + d + "/curves_folder",
                    &output),
            0)
      << output;
  const auto curves_bag = json(d + "/curves_bag/curves.json");
  const auto curves_folder = json(d + "/curves_folder/curves.json");
  EXPECT_EQ(curves_bag["in_scene_frames"], 8);
  EXPECT_EQ(curves_bag["min_inlier_ratio"]["curve"], curves_folder["min_inlier_ratio"]["curve"]);
}

TEST(BagTools, MakeBagPlaysAWalksTrajectoryAsTfAtEveryTick) {
  TempDir dir("bag_walk");
  const std::string d = dir.str();
  std::string output;
  ASSERT_EQ(runTool("synthesize --output " + d +
                        "/b --rooms 2 --seed 5 --train-frames 2 --test-frames 1 --width 80 "
                        "--height 60",
                    &output),
            0)
      << output;
  const std::string walk = d + "/b/walk";
  const std::string make_bag = "make_bag --dataset " + walk + " --frames 0-499999 --rate 30 --tf " +
                               "--tf-trajectory " + walk + "/walk_poses.txt --output " + d +
                               "/walk.bag";
  ASSERT_EQ(runTool(make_bag, &output), 0) << output;
  const auto trajectory = relocalizer::readTumTrajectory(walk + "/walk_poses.txt");
  ASSERT_TRUE(trajectory.ok()) << trajectory.error();
  relocalizer::DatasetOptions rendered;
  rendered.frames = "0-499999";  // the walk's frames, not the rooms' test frames
  auto folder = relocalizer::openDataset(walk, rendered);
  ASSERT_TRUE(folder.ok()) << folder.error();
  ASSERT_GT((*folder)->size(), 500u) << "two rooms' rendered ticks";
  ASSERT_GT(trajectory->size(), (*folder)->size() + 200) << "corridor ticks too";

  // TF at every tick, stamped on the frames' clock: the walk starts at tick 0.
  {
    rosbag::Bag bag(d + "/walk.bag", rosbag::bagmode::Read);
    size_t k = 0;
    for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery("/tf"))) {
      const auto tf = m.instantiate<tf2_msgs::TFMessage>();
      ASSERT_TRUE(tf && tf->transforms.size() == 2u);
      ASSERT_LT(k, trajectory->size());
      EXPECT_EQ(tf->transforms[1].header.stamp, ros::Time(1.0 + k / 30.0)) << k;
      const Pose camera = fromTransformMsg(tf->transforms[0].transform) *
                          fromTransformMsg(tf->transforms[1].transform);
      const Pose truth = relocalizer::poseFromTranslationQuaternion((*trajectory)[k].translation,
                                                                    (*trajectory)[k].rotation);
      EXPECT_LT(relocalizer::translationError(camera, truth), 1e-9) << k;
      ++k;
    }
    EXPECT_EQ(k, trajectory->size());
    size_t images = 0;
    for (const rosbag::MessageInstance& m :
         rosbag::View(bag, rosbag::TopicQuery("/camera/rgb/image_raw"))) {
      const auto image = m.instantiate<sensor_msgs::Image>();
      ASSERT_TRUE(image);
      ASSERT_LT(images, (*folder)->size());
      EXPECT_EQ(static_cast<int>(image->header.seq), (*folder)->id(images));
      EXPECT_EQ(image->header.stamp, ros::Time(1.0 + (*folder)->id(images) / 30.0));
      ++images;
    }
    EXPECT_EQ(images, (*folder)->size());
  }
  // Read back as a SLAM recording: every frame's pose from the TF chain is the folder's.
  auto bag = BagDataset::open(d + "/walk.bag", BagOptions{});
  ASSERT_TRUE(bag.ok()) << bag.error();
  ASSERT_EQ((*bag)->size(), (*folder)->size());
  for (size_t i = 0; i < (*bag)->size(); i += 50) {
    ASSERT_TRUE((*bag)->groundTruth(i).has_value()) << i;
    EXPECT_LT(relocalizer::translationError(*(*bag)->groundTruth(i), *(*folder)->groundTruth(i)),
              1e-6)
        << (*bag)->id(i);
  }

  EXPECT_EQ(runTool("make_bag --dataset " + walk + " --tf-trajectory " + walk +
                        "/walk_poses.txt --output " + d + "/no_tf.bag",
                    &output),
            2);
  EXPECT_NE(output.find("--tf-trajectory needs --tf"), std::string::npos) << output;
}
