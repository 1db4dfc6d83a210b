// Pose hints through the node: one room as two places ("first" in map, "twin"
// in twin_map), so every frame fits both alike and only a hint names the
// place. Hints in ~relocalize calls and on initialpose are used (the answer
// comes from the hinted place, at the true pose), a 2D hint in another frame
// comes in through TF, a hint in a frame TF cannot reach is refused with its
// reason, and a node never takes its own initialpose messages as hints.

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <cmath>

#include "../../src/ros/node/node_hints.h"
#include "node_test_support.h"

using namespace relocalizer_test;
using HintMsg = geometry_msgs::PoseWithCovarianceStamped;

namespace {

std::vector<FrameMessages>* g_frames = nullptr;
CameraPublisher* g_camera = nullptr;
Listener<rosgraph_msgs::Log>* g_rosout = nullptr;
ros::Publisher* g_initialpose = nullptr;

// The frame of the 2D hint: 1 m along map's x, turned 90 degrees.
Pose mapFromFloor() {
  return Eigen::Translation3d(1.0, 0.0, 0.0) *
         Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
}

// Waits until `count` subscribers listen on initialpose.
void waitForHintSubscribers(uint32_t count) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(30.0);
  while (g_initialpose->getNumSubscribers() < count && ros::WallTime::now() < end)
    ros::WallDuration(0.05).sleep();
}

// The camera pose `pose` as a hint in `frame`: 0.3 m and 0.2 rad standard deviations.
HintMsg hintAt(const Pose& pose, const std::string& frame) {
  HintMsg msg;
  msg.header.frame_id = frame;
  msg.header.stamp = ros::Time::now();
  msg.pose = relocalizer_ros::toPoseWithCovarianceMsg(pose, relocalizer::Matrix6d::Zero());
  for (int i = 0; i < 6; ++i) msg.pose.covariance[i * 7] = i < 3 ? 0.09 : 0.04;
  return msg;
}

relocalizer::Relocalize::Response call(const FrameMessages& frame,
                                       const std::optional<HintMsg>& hint = std::nullopt) {
  relocalizer::Relocalize::Request request;
  request.timeout = 20.0;
  request.wait_for_next = true;
  if (hint) {
    request.use_hint = true;
    request.hint = *hint;
  }
  return callWhilePublishing(
      [sent = frame]() mutable {
        sent.stamp(ros::Time::now());
        g_camera->publish(sent);
      },
      request);
}

void expectAnswer(const relocalizer::Relocalize::Response& response, const std::string& place,
                  const std::string& frame, const Pose& truth) {
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_EQ(response.place, place);
  EXPECT_EQ(response.pose.header.frame_id, frame);
  EXPECT_LT(translationError(response.pose.pose.pose, truth), 0.05);
  EXPECT_LT(rotationError(response.pose.pose.pose, truth), 5.0);
}

bool logged(uint8_t level, const std::string& part, double seconds = 10.0) {
  return g_rosout
      ->waitFor(
          [&](const rosgraph_msgs::Log& log) {
            return log.name == "/relocalizer" && log.level == level && contains(log.msg, part);
          },
          seconds)
      .has_value();
}

}  // namespace

TEST(Hints, WithoutAHintTheTwinPlacesAreAmbiguous) {
  ASSERT_TRUE(g_camera->waitForNode());
  const relocalizer::Relocalize::Response response = call(g_frames->front());
  EXPECT_FALSE(response.success) << "answered by " << response.place;
  EXPECT_TRUE(contains(response.message, "ambiguous place")) << response.message;
}

TEST(Hints, AHintInTheCallNamesThePlaceItsFrameBelongsTo) {
  const FrameMessages& frame = g_frames->at(3);
  expectAnswer(call(frame, hintAt(frame.truth, "twin_map")), "twin", "twin_map", frame.truth);
  expectAnswer(call(frame, hintAt(frame.truth, "map")), "first", "map", frame.truth);
  // A call with a hint leaves no trace: the next call without one is ambiguous again.
  EXPECT_FALSE(call(frame).success);
}

TEST(Hints, ATwoDimensionalHintInAnotherFrameComesThroughTf) {
  // RViz's 2D Pose Estimate in `floor`: x, y and yaw, the arrow along the
  // camera's heading.
  const FrameMessages& frame = g_frames->at(6);
  const Pose in_floor = mapFromFloor().inverse() * frame.truth;
  const Eigen::Vector3d heading = in_floor.linear().col(2);
  const Pose arrow =
      Eigen::Translation3d(in_floor.translation().x(), in_floor.translation().y(), 0) *
      Eigen::AngleAxisd(std::atan2(heading.y(), heading.x()), Eigen::Vector3d::UnitZ());
  HintMsg hint = hintAt(arrow, "floor");
  hint.pose.covariance.fill(0.0);
  hint.pose.covariance[0] = hint.pose.covariance[7] = 0.25;
  hint.pose.covariance[35] = 0.07;
  expectAnswer(call(frame, hint), "first", "map", frame.truth);
}

TEST(Hints, AHintOnInitialposeIsUsedUntilAnAnswerSpendsIt) {
  const FrameMessages& frame = g_frames->at(9);
  g_rosout->clear();
  waitForHintSubscribers(1);
  g_initialpose->publish(hintAt(frame.truth, "twin_map"));
  ASSERT_TRUE(logged(rosgraph_msgs::Log::INFO, "pose hint on /initialpose from " +
                                                   ros::this_node::getName() + " in twin_map"));
  expectAnswer(call(frame), "twin", "twin_map", frame.truth);
  EXPECT_TRUE(logged(rosgraph_msgs::Log::INFO, "with the pose hint, which is now spent"));
  EXPECT_FALSE(call(frame).success);
}

TEST(Hints, AHintInAFrameTfCannotReachIsRefusedWithItsReason) {
  const FrameMessages& frame = g_frames->at(12);
  const relocalizer::Relocalize::Response response = call(frame, hintAt(frame.truth, "nowhere"));
  EXPECT_FALSE(response.success);
  EXPECT_TRUE(contains(response.message,
                       "hint refused: frame 'nowhere' is no place's map frame (map, twin_map)"))
      << response.message;
  g_initialpose->publish(hintAt(frame.truth, "nowhere"));
  EXPECT_TRUE(logged(rosgraph_msgs::Log::WARN, "refused: frame 'nowhere' is no place's map frame"));
  HintMsg spinning = hintAt(frame.truth, "map");
  spinning.pose.pose.orientation.w = 0.0;
  spinning.pose.pose.orientation.x = 0.0;
  spinning.pose.pose.orientation.y = 0.0;
  spinning.pose.pose.orientation.z = 0.0;
  EXPECT_TRUE(contains(call(frame, spinning).message, "not a unit quaternion"));
}

// Issue 38 (W1-W4): a hint's frame and covariance that make no sense are
// refused saying what is wrong, in a short line of printable text.
TEST(Hints, ANonsenseHintIsRefusedSayingWhatIsWrong) {
  const FrameMessages& frame = g_frames->at(15);
  const auto refusal = [&](const HintMsg& hint) {
    const relocalizer::Relocalize::Response response = call(frame, hint);
    EXPECT_FALSE(response.success);
    EXPECT_LT(response.message.size(), 400u) << response.message.substr(0, 400);
    EXPECT_EQ(response.message.find_first_of("\n\r\x1b"), std::string::npos);
    return response.message;
  };
  HintMsg huge = hintAt(frame.truth, "map");
  huge.pose.covariance[0] = 1e300;
  std::string why = refusal(huge);
  EXPECT_TRUE(contains(why, "covariance is too large: 1e+300 at x, x")) << why;
  EXPECT_FALSE(contains(why, "all zero")) << why;
  HintMsg nan = hintAt(frame.truth, "map");
  nan.pose.covariance[7] = std::nan("");
  why = refusal(nan);
  EXPECT_TRUE(contains(why, "covariance is not finite")) << why;
  HintMsg free_axes = hintAt(frame.truth, "map");
  for (int i = 0; i < 6; ++i) free_axes.pose.covariance[i * 7] = 1e6;
  why = refusal(free_axes);
  EXPECT_TRUE(contains(why, "constrains nothing")) << why;
  EXPECT_FALSE(contains(why, "all zero")) << why;

  const std::string long_frame(10000, 'f');
  why = refusal(hintAt(frame.truth, long_frame));
  EXPECT_TRUE(contains(why, "header.frame_id '" + std::string(40, 'f') + "... (10000 bytes)'"))
      << why.substr(0, 400);
  EXPECT_TRUE(contains(why, "is longer than 128 bytes")) << why.substr(0, 400);
  why = refusal(hintAt(frame.truth, "map\n[ERROR] forged"));
  EXPECT_TRUE(contains(why, "'map?[ERROR] forged' holds a character other than")) << why;
  g_rosout->clear();
  g_initialpose->publish(hintAt(frame.truth, "map\x1b[2J" + long_frame));
  const auto warning = g_rosout->waitFor(
      [&](const rosgraph_msgs::Log& log) {
        return log.name == "/relocalizer" && contains(log.msg, "header.frame_id");
      },
      10.0);
  ASSERT_TRUE(warning) << "no warning of the refused hint";
  EXPECT_LT(warning->msg.size(), 400u);
  EXPECT_EQ(warning->msg.find('\x1b'), std::string::npos);
}

TEST(Hints, ANodeIgnoresItsOwnInitialposeMessages) {
  // This test node listens too: what it publishes itself on initialpose (as
  // forward_initialpose does) must not become its hint, while the relocalizer
  // node, another node, takes the same message.
  relocalizer_ros::HintSettings params;
  tf2_ros::Buffer tf;  // the hint is in the map frame: no TF needed, so no listener
  relocalizer_ros::NodeHints own(ros::NodeHandle(), params, tf,
                                 [] { return std::vector<std::string>{"map"}; });
  waitForHintSubscribers(2);
  g_rosout->clear();
  const HintMsg hint = hintAt(g_frames->front().truth, "map");
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(30.0);
  while (own.ownMessagesIgnored() == 0 && ros::WallTime::now() < end) {
    g_initialpose->publish(hint);
    ros::WallDuration(0.1).sleep();
  }
  EXPECT_GT(own.ownMessagesIgnored(), 0u);
  EXPECT_FALSE(own.pending());
  EXPECT_TRUE(logged(rosgraph_msgs::Log::INFO,
                     "pose hint on /initialpose from " + ros::this_node::getName() + " in map"));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_hints");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  std::vector<FrameMessages> frames = loadFixtureFrames();
  CameraPublisher camera;
  Listener<rosgraph_msgs::Log> rosout("/rosout", 1000);
  ros::NodeHandle nh;
  ros::Publisher initialpose = nh.advertise<HintMsg>("initialpose", 5);
  tf2_ros::StaticTransformBroadcaster static_tf;
  geometry_msgs::TransformStamped floor;
  floor.header.frame_id = "map";
  floor.header.stamp = ros::Time::now();
  floor.child_frame_id = "floor";
  floor.transform = relocalizer_ros::toTransformMsg(mapFromFloor());
  static_tf.sendTransform(floor);
  g_frames = &frames;
  g_camera = &camera;
  g_rosout = &rosout;
  g_initialpose = &initialpose;
  const int status = RUN_ALL_TESTS();
  spinner.stop();
  return status;
}
