// The node in continuous mode, fed at 10 Hz by fixture_camera with max_rate 2:
// results come at the capped rate, the surplus is dropped and counted, and
// every answer is a good pose. (hztest checks the rate itself.)

#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "node_test_support.h"

using namespace relocalizer_test;

TEST(Continuous, RelocalizesAtTheCappedRateAndCountsDroppedFrames) {
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener tf_listener(buffer);
  Listener<ResultMsg> results("/relocalizer/result");
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(30.0);
  while (results.messages().size() < 6 && ros::WallTime::now() < give_up)
    ros::WallDuration(0.05).sleep();
  ASSERT_GE(results.messages().size(), 6u) << "fewer than 6 results in 30 s";
  const std::vector<ResultMsg> got = results.messages();
  for (const ResultMsg& r : got) {
    EXPECT_TRUE(r.success) << r.message;
    EXPECT_EQ(r.header.frame_id, "map");
    EXPECT_GT(r.time_forest, 0.0f);
  }
  const ResultMsg& last = got.back();
  // At 10 Hz in and at most 2 Hz out, most frames are dropped, and counted.
  EXPECT_GT(last.frames_dropped, 0u);
  EXPECT_LE(last.frames_processed + last.frames_dropped, last.frames_received);
  EXPECT_GE(last.frames_processed + last.frames_dropped + 1, last.frames_received);
  // Consecutive answers respect max_rate (2 Hz) in frame time, with scheduling slack.
  for (size_t i = 1; i < got.size(); ++i)
    EXPECT_GT((got[i].header.stamp - got[i - 1].header.stamp).toSec(), 0.3);
  // map -> camera follows every answer.
  geometry_msgs::TransformStamped tf;
  EXPECT_NO_THROW(
      tf = buffer.lookupTransform("map", kCameraFrame, last.header.stamp, ros::Duration(3.0)));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_continuous");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int code = RUN_ALL_TESTS();
  spinner.stop();
  return code;
}
