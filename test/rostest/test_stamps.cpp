// True stamps: a camera turning at 90 deg/s whose depth image is taken 20 ms
// after its colour image (and stamped so), as a Kinect v1 does. Depth ICP
// aligns the pose with the depth, so the node stamps the answer (~result, the
// service's pose) with the depth stamp, and the pose is nearer the true pose
// at that stamp than at the colour stamp. stamps_surface_off.test runs it
// against a node without depth ICP: the solver's pose, from the depth's 3D
// points, holds at the depth stamp too.

#include <map>
#include <set>

#include "node_test_support.h"
#include "relocalizer/sim/synthetic_scene.h"

using namespace relocalizer_test;

namespace {

constexpr double kDepthLag = 0.02;                  // s, depth after colour
constexpr double kTurnRate = 90.0 * M_PI / 180.0;   // rad/s, about the camera's y (pan)
constexpr int kTrainFrames = 60, kTestFrames = 20;  // as make_fixture.sh synthesizes
constexpr int kWidth = 320, kHeight = 240;

// The camera at `seconds` from the middle of the colour-depth interval.
Pose turned(const Pose& middle, double seconds) {
  Pose pose = middle;
  pose.linear() =
      middle.linear() * Eigen::AngleAxisd(kTurnRate * seconds, Eigen::Vector3d::UnitY()).matrix();
  return pose;
}

struct LaggedFrame {
  FrameMessages messages;
  Pose colour_truth, depth_truth;
};

// Fixture test frame `index`, colour rendered where the camera is at the
// colour stamp and depth where it is kDepthLag later.
LaggedFrame laggedFrame(const relocalizer::SyntheticRoom& room, const Pose& middle, int index) {
  const auto camera = relocalizer::CameraIntrinsics::kinectDefault().scaledTo(kWidth, kHeight);
  LaggedFrame lagged;
  lagged.colour_truth = turned(middle, -kDepthLag / 2);
  lagged.depth_truth = turned(middle, kDepthLag / 2);
  const int time = kTrainFrames + index;
  const relocalizer::RgbdFrame colour = room.render(lagged.colour_truth, camera, time);
  const relocalizer::RgbdFrame depth = room.render(lagged.depth_truth, camera, time);
  FrameMessages& m = lagged.messages;
  m.colour = imageMessage(colour.colour, sensor_msgs::image_encodings::BGR8);
  m.depth = imageMessage(relocalizer::depthToMillimetres(depth.depth),
                         sensor_msgs::image_encodings::TYPE_16UC1);
  m.colour.header.frame_id = m.depth.header.frame_id = m.info.header.frame_id = kCameraFrame;
  m.info.width = camera.width;
  m.info.height = camera.height;
  m.info.K = {camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1};
  return lagged;
}

}  // namespace

TEST(Stamps, AnswerHoldsAtTheDepthStamp) {
  const relocalizer::SyntheticRoom room(1);
  const auto path = room.trajectories(kTrainFrames, kTestFrames).test;
  Listener<ResultMsg> results("/relocalizer/result");
  CameraPublisher camera;
  ASSERT_TRUE(camera.waitForNode());
  int answered = 0;
  double depth_error_sum = 0, colour_error_sum = 0;
  // Every stamp published, across frames: a call may answer a set of the
  // previous frame still on its way.
  std::mutex stamps_mutex;
  std::map<ros::Time, int> depth_stamps, colour_stamps;  // to the frame's index
  std::map<int, LaggedFrame> frames;
  for (int index : {0, 4, 8, 12, 16}) {
    LaggedFrame& frame = frames[index] = laggedFrame(room, path[index], index);
    const auto answer = callWhilePublishing(
        [&] {
          const ros::Time now = ros::Time::now();
          {
            std::lock_guard<std::mutex> lock(stamps_mutex);
            colour_stamps[now] = index;
            depth_stamps[now + ros::Duration(kDepthLag)] = index;
          }
          frame.messages.colour.header.stamp = frame.messages.info.header.stamp = now;
          frame.messages.depth.header.stamp = now + ros::Duration(kDepthLag);
          camera.publish(frame.messages);
        },
        10.0);
    if (!answer.success) {
      ADD_FAILURE() << "frame " << index << ": " << answer.message;
      continue;
    }
    ++answered;
    const ros::Time stamp = answer.pose.header.stamp;
    int answered_index = -1;
    {
      std::lock_guard<std::mutex> lock(stamps_mutex);
      EXPECT_EQ(colour_stamps.count(stamp), 0u) << "frame " << index << ": a colour stamp";
      auto found = depth_stamps.find(stamp);
      ASSERT_NE(found, depth_stamps.end()) << "frame " << index << ": not a depth stamp";
      answered_index = found->second;
    }
    const LaggedFrame& truth = frames.at(answered_index);
    EXPECT_TRUE(results.waitFor(
        [&](const ResultMsg& r) { return r.success && r.header.stamp == stamp; }, 10.0))
        << "frame " << index << ": no ~result at the answer's stamp";
    const double at_depth = rotationError(answer.pose.pose.pose, truth.depth_truth);
    const double at_colour = rotationError(answer.pose.pose.pose, truth.colour_truth);
    std::printf(
        "frame %d: rotation error %.3f deg at the depth stamp, %.3f at the colour stamp; "
        "%.1f mm\n",
        answered_index, at_depth, at_colour,
        1000 * translationError(answer.pose.pose.pose, truth.depth_truth));
    EXPECT_LT(at_depth, at_colour) << "frame " << answered_index;
    depth_error_sum += at_depth;
    colour_error_sum += at_colour;
  }
  ASSERT_GE(answered, 4);
  // The turn between the stamps is 1.8 deg: scored at the colour stamp, the
  // answers are off by most of it.
  EXPECT_LT(depth_error_sum / answered, 0.5 * colour_error_sum / answered);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_stamps");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int code = RUN_ALL_TESTS();
  spinner.stop();
  return code;
}
