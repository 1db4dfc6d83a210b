// Hand-off to the robot's localizer: with forward_initialpose and
// set_pose_service, every accepted pose reaches a fake amcl on /initialpose and
// a fake robot_localization SetPose service exactly as answered (stamp, frame,
// pose, covariance), each frame once even when two calls answer it; a frame
// that gets no pose is not handed off; a service slower than the answers holds
// none of them up.
// handoff_frame.test (HandoffFrame): a handoff_frame that TF does not bring
// holds up no answer, even at tf_timeout 10 s, and once TF brings it the pose
// handed off is that frame's.

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <relocalizer/SetPose.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <cmath>

#include "node_test_support.h"

using namespace relocalizer_test;
using PoseMsg = geometry_msgs::PoseWithCovarianceStamped;

namespace {

// Longer than a relocalization: calls must not wait for it.
constexpr double kServiceSeconds = 3.0;

// robot_localization's SetPose as a filter serves it, but slow.
class FakeFilter {
 public:
  FakeFilter() {
    server_ =
        ros::NodeHandle().advertiseService("/fake_ekf/set_pose", &FakeFilter::onSetPose, this);
  }
  std::vector<PoseMsg> poses() {
    std::lock_guard<std::mutex> lock(mutex_);
    return poses_;
  }

 private:
  bool onSetPose(relocalizer::SetPose::Request& request, relocalizer::SetPose::Response&) {
    ros::WallDuration(kServiceSeconds).sleep();
    std::lock_guard<std::mutex> lock(mutex_);
    poses_.push_back(request.pose);
    return true;
  }
  ros::ServiceServer server_;
  std::mutex mutex_;
  std::vector<PoseMsg> poses_;
};

relocalizer::Relocalize::Response callLatest() {
  relocalizer::Relocalize srv;
  srv.request.timeout = 10.0;
  srv.request.wait_for_next = false;
  EXPECT_TRUE(ros::service::call("/relocalizer/relocalize", srv));
  return srv.response;
}

void expectSamePose(const PoseMsg& handed, const PoseMsg& answered, const std::string& where) {
  EXPECT_EQ(handed.header.stamp, answered.header.stamp) << where;
  EXPECT_EQ(handed.header.frame_id, answered.header.frame_id) << where;
  EXPECT_EQ(handed.pose.pose.position.x, answered.pose.pose.position.x) << where;
  EXPECT_EQ(handed.pose.pose.position.y, answered.pose.pose.position.y) << where;
  EXPECT_EQ(handed.pose.pose.position.z, answered.pose.pose.position.z) << where;
  EXPECT_EQ(handed.pose.pose.orientation.w, answered.pose.pose.orientation.w) << where;
  EXPECT_EQ(handed.pose.pose.orientation.x, answered.pose.pose.orientation.x) << where;
  EXPECT_EQ(handed.pose.covariance, answered.pose.covariance) << where;
}

}  // namespace

TEST(Handoff, AcceptedPosesReachAmclAndTheFilterOnceEach) {
  FakeFilter filter;
  Listener<PoseMsg> amcl("/initialpose");
  std::vector<FrameMessages> frames = loadFixtureFrames();
  std::vector<FrameMessages> elsewhere = loadFixtureFrames("scene2");
  CameraPublisher camera;
  ASSERT_TRUE(camera.waitForNode());
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(30.0);
  while (!amcl.connected() && ros::WallTime::now() < give_up) ros::WallDuration(0.05).sleep();
  ASSERT_TRUE(amcl.connected()) << "the node does not publish /initialpose";

  std::vector<PoseMsg> accepted;
  // One frame, answered by two calls one after the other (two relocalizations
  // of one frame): handed off once.
  frames[0].stamp(ros::Time::now());
  camera.publish(frames[0]);
  const auto first = callLatest();
  ASSERT_TRUE(first.success) << first.message;
  const ros::WallTime before_second = ros::WallTime::now();
  const auto again = callLatest();
  ASSERT_TRUE(again.success) << again.message;
  EXPECT_EQ(again.pose.header.stamp, first.pose.header.stamp) << "not the same frame";
  // The slow filter is still busy with the first pose: the call did not wait for it.
  EXPECT_LT((ros::WallTime::now() - before_second).toSec(), kServiceSeconds);
  accepted.push_back(first.pose);

  // More frames, and between them a frame of another room, which gets no pose.
  for (size_t i : {5, 10}) {
    auto& frame = frames[i];
    auto answer = callWhilePublishing(
        [&] {
          frame.stamp(ros::Time::now());
          camera.publish(frame);
        },
        10.0);
    ASSERT_TRUE(answer.success) << answer.message;
    accepted.push_back(answer.pose);
    auto& other = elsewhere[i];
    auto no_pose = callWhilePublishing(
        [&] {
          other.stamp(ros::Time::now());
          camera.publish(other);
        },
        10.0);
    ASSERT_FALSE(no_pose.success) << "a frame of another room was placed";
  }

  // Every accepted pose arrives on /initialpose, once, as answered, and nothing
  // else (the refused frames included).
  for (const PoseMsg& pose : accepted)
    EXPECT_TRUE(
        amcl.waitFor([&](const PoseMsg& m) { return m.header.stamp == pose.header.stamp; }, 10.0))
        << "no /initialpose for the answer at " << pose.header.stamp;
  // The filter gets the latest pose at least (poses that came while it was busy
  // are replaced by newer ones).
  const ros::Time last = accepted.back().header.stamp;
  const ros::WallTime filter_deadline = ros::WallTime::now() + ros::WallDuration(20.0);
  while ((filter.poses().empty() || filter.poses().back().header.stamp != last) &&
         ros::WallTime::now() < filter_deadline)
    ros::WallDuration(0.05).sleep();
  ros::WallDuration(1.0).sleep();  // room for a duplicate to show up

  const std::vector<PoseMsg> forwarded = amcl.messages();
  ASSERT_EQ(forwarded.size(), accepted.size()) << "each accepted pose once, nothing else";
  for (size_t i = 0; i < accepted.size(); ++i)
    expectSamePose(forwarded[i], accepted[i], "initialpose " + std::to_string(i));

  const std::vector<PoseMsg> set = filter.poses();
  ASSERT_FALSE(set.empty()) << "the SetPose service was never called";
  ASSERT_LE(set.size(), accepted.size());
  EXPECT_EQ(set.front().header.stamp, accepted.front().header.stamp);
  EXPECT_EQ(set.back().header.stamp, last);
  for (size_t i = 0; i < set.size(); ++i) {
    auto same = std::find_if(accepted.begin(), accepted.end(), [&](const PoseMsg& a) {
      return a.header.stamp == set[i].header.stamp;
    });
    ASSERT_NE(same, accepted.end()) << "SetPose got a pose that was not accepted";
    expectSamePose(set[i], *same, "set_pose " + std::to_string(i));
    if (i > 0) {
      EXPECT_GT(set[i].header.stamp, set[i - 1].header.stamp) << "not in order";
    }
  }
}

TEST(HandoffFrame, AnAnswerNeverWaitsForTheHandoffFramesTf) {
  Listener<PoseMsg> amcl("/initialpose");
  std::vector<FrameMessages> frames = loadFixtureFrames();
  CameraPublisher camera;
  ASSERT_TRUE(camera.waitForNode());
  double tf_timeout = 0.0;
  ASSERT_TRUE(ros::param::get("/relocalizer/tf_timeout", tf_timeout));
  ASSERT_GE(tf_timeout, 10.0) << "the launch file sets the longest tf_timeout";

  // base_footprint is in no TF yet: before issue 38 each call waited tf_timeout.
  for (size_t i : {0, 5}) {
    frames[i].stamp(ros::Time::now());
    camera.publish(frames[i]);
    const ros::WallTime start = ros::WallTime::now();
    const auto answer = callLatest();
    const double seconds = (ros::WallTime::now() - start).toSec();
    ASSERT_TRUE(answer.success) << answer.message;
    EXPECT_LT(seconds, tf_timeout / 2) << "the answer waited for the hand-off's TF";
  }
  EXPECT_TRUE(amcl.messages().empty()) << "a pose was handed off without its frame's TF";

  // Once TF has the frame (0.3 m along the camera's y axis), the pose handed
  // off is that frame's.
  tf2_ros::StaticTransformBroadcaster broadcaster;
  geometry_msgs::TransformStamped base;
  base.header.frame_id = kCameraFrame;
  base.child_frame_id = "base_footprint";
  base.transform.translation.y = 0.3;
  base.transform.rotation.w = 1.0;
  broadcaster.sendTransform(base);
  frames[10].stamp(ros::Time::now());
  camera.publish(frames[10]);
  const auto answer = callLatest();
  ASSERT_TRUE(answer.success) << answer.message;
  const auto handed = amcl.waitFor(
      [&](const PoseMsg& m) { return m.header.stamp == answer.pose.header.stamp; }, 3 * tf_timeout);
  ASSERT_TRUE(handed) << "the answer at " << answer.pose.header.stamp << " was not handed off";
  const auto& a = answer.pose.pose.pose.position;
  const auto& b = handed->pose.pose.position;
  EXPECT_NEAR(std::hypot(a.x - b.x, a.y - b.y, a.z - b.z), 0.3, 1e-6);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_handoff");
  ros::AsyncSpinner spinner(4);
  spinner.start();
  const int code = RUN_ALL_TESTS();
  spinner.stop();
  return code;
}
