// The node with an odom frame (REP 105): map -> odom from the relocalized pose
// and a fake odom -> camera, post-dated and re-broadcast; a missing odom ->
// camera is a failure result, not a wait.

#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include "node_test_support.h"

using namespace relocalizer_test;

namespace {

std::vector<FrameMessages>* g_frames = nullptr;
CameraPublisher* g_camera = nullptr;

// Where the fake odometry puts the camera: far from the map pose, so map -> odom
// is not the identity and a wrong composition order shows.
Pose odomToCamera() {
  Pose pose = Pose::Identity();
  pose.linear() = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                  Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(0.8, -0.4, 0.25);
  return pose;
}

}  // namespace

TEST(OdomMode, PublishesMapToOdomThatComposesWithOdometryToTheCameraPose) {
  tf2_ros::TransformBroadcaster broadcaster;
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener tf_listener(buffer);
  Listener<tf2_msgs::TFMessage> tf_messages("/tf", 1000);
  ASSERT_TRUE(g_camera->waitForNode());
  // The node must hear our odometry and we its TF before the first frame.
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(10.0);
  while (!tf_messages.connected() && ros::WallTime::now() < give_up)
    ros::WallDuration(0.05).sleep();
  ros::WallDuration(0.5).sleep();

  FrameMessages frame = (*g_frames)[4];
  // Leading slashes are a tf1 habit the node must tolerate.
  frame.colour.header.frame_id = frame.depth.header.frame_id = std::string("/") + kCameraFrame;
  const Pose odom_T_camera = odomToCamera();
  const auto response = callWhilePublishing(
      [&] {
        frame.stamp(ros::Time::now());
        geometry_msgs::TransformStamped odom;
        odom.header.stamp = frame.colour.header.stamp;
        odom.header.frame_id = "odom";
        odom.child_frame_id = kCameraFrame;
        odom.transform = relocalizer_ros::toTransformMsg(odom_T_camera);
        broadcaster.sendTransform(odom);
        g_camera->publish(frame);
      },
      5.0);
  ASSERT_TRUE(response.success) << response.message;
  const ros::Time stamp = response.pose.header.stamp;
  const Pose map_T_camera = relocalizer_ros::fromPoseMsg(response.pose.pose.pose);
  EXPECT_LT(relocalizer::translationError(map_T_camera, frame.truth), 0.05);
  EXPECT_LT(relocalizer::rotationErrorDegrees(map_T_camera, frame.truth), 5.0);

  geometry_msgs::TransformStamped map_to_odom;
  ASSERT_NO_THROW(map_to_odom =
                      buffer.lookupTransform("map", "odom", ros::Time(0), ros::Duration(3.0)));
  const Pose map_T_odom = relocalizer_ros::fromTransformMsg(map_to_odom.transform);
  const Pose expected = map_T_camera * odom_T_camera.inverse();
  EXPECT_LT(relocalizer::translationError(map_T_odom, expected), 1e-5);
  EXPECT_LT(relocalizer::rotationErrorDegrees(map_T_odom, expected), 1e-3);
  // The chain map -> odom -> camera lands on the truth.
  const Pose chained = map_T_odom * odom_T_camera;
  EXPECT_LT(relocalizer::translationError(chained, frame.truth), 0.05);
  EXPECT_LT(relocalizer::rotationErrorDegrees(chained, frame.truth), 5.0);

  // Post-dated by transform_tolerance (0.1 s in the launch file), then
  // re-broadcast at tf_rate with later stamps.
  ros::WallDuration(0.6).sleep();
  std::vector<ros::Time> stamps;
  for (const auto& message : tf_messages.messages())
    for (const auto& t : message.transforms)
      if (t.header.frame_id == "map" && t.child_frame_id == "odom")
        stamps.push_back(t.header.stamp);
  ASSERT_FALSE(stamps.empty());
  EXPECT_TRUE(std::find(stamps.begin(), stamps.end(), stamp + ros::Duration(0.1)) != stamps.end());
  EXPECT_GE(std::count_if(stamps.begin(), stamps.end(),
                          [&](const ros::Time& s) { return s > stamp + ros::Duration(0.1); }),
            3);
}

TEST(OdomMode, MissingOdometryIsAFailureResultNotAWait) {
  FrameMessages frame = (*g_frames)[6];
  frame.colour.header.frame_id = frame.depth.header.frame_id = "camera_without_odometry";
  const ros::WallTime start = ros::WallTime::now();
  const auto response = callWhilePublishing(
      [&] {
        frame.stamp(ros::Time::now());
        g_camera->publish(frame);
      },
      5.0);
  EXPECT_FALSE(response.success);
  EXPECT_TRUE(contains(response.message,
                       "relocalized in place 'model', but no odom -> camera_without_odometry"))
      << response.message;
  EXPECT_LT((ros::WallTime::now() - start).toSec(), 4.0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_odom");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  std::vector<FrameMessages> frames = loadFixtureFrames();
  CameraPublisher camera;
  g_frames = &frames;
  g_camera = &camera;
  const int code = RUN_ALL_TESTS();
  spinner.stop();
  return code;
}
