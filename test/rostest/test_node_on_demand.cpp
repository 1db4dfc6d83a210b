// The node in on_demand mode with direct map -> camera TF: interface, service
// semantics, accuracy on the synthetic fixture, and bad input.

#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>

#include "node_test_support.h"

using namespace relocalizer_test;

namespace {

std::vector<FrameMessages>* g_frames = nullptr;
CameraPublisher* g_camera = nullptr;
Listener<ResultMsg>* g_results = nullptr;
Listener<rosgraph_msgs::Log>* g_rosout = nullptr;
tf2_ros::Buffer* g_tf = nullptr;  // listening from the start: a late /tf connection misses transforms

bool warned(const std::string& part, double seconds = 5.0) {
  return g_rosout
      ->waitFor([&](const rosgraph_msgs::Log& log) {
        return log.name == "/relocalizer" && log.level >= rosgraph_msgs::Log::WARN && contains(log.msg, part);
      }, seconds)
      .has_value();
}

bool failureResult(const std::string& part, double seconds = 5.0) {
  return g_results
      ->waitFor([&](const ResultMsg& r) { return !r.success && contains(r.message, part); }, seconds)
      .has_value();
}

// Publishes `frame` restamped with the current time.
std::function<void()> sending(FrameMessages frame, bool with_info = true) {
  return [frame, with_info]() mutable {
    frame.stamp(ros::Time::now());
    g_camera->publish(frame, with_info);
  };
}

void expectAccurate(const relocalizer::Relocalize::Response& response, const Pose& truth) {
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_LT(translationError(response.pose.pose.pose, truth), 0.05);
  EXPECT_LT(rotationError(response.pose.pose.pose, truth), 5.0);
  EXPECT_EQ(response.pose.header.frame_id, "map");
  EXPECT_GT(response.point_inliers, 0u);
  EXPECT_GT(response.processing_time, 0.0f);
}

}  // namespace

TEST(OnDemand, AdvertisesTopicsAndService) {
  ASSERT_TRUE(ros::service::waitForService("/relocalizer/relocalize", ros::Duration(30)));
  ros::master::V_TopicInfo topics;
  ASSERT_TRUE(ros::master::getTopics(topics));
  auto advertised = [&](const std::string& name, const std::string& type) {
    for (const auto& t : topics)
      if (t.name == name) return t.datatype == type;
    return false;
  };
  EXPECT_TRUE(advertised("/relocalizer/pose", "geometry_msgs/PoseWithCovarianceStamped"));
  EXPECT_TRUE(advertised("/relocalizer/result", "relocalizer/RelocalizationResult"));
  EXPECT_TRUE(g_camera->waitForNode()) << "the node does not subscribe to rgb/image, depth/image, rgb/camera_info";
}

TEST(OnDemand, CallBeforeAnyFrameFailsWithinItsTimeout) {
  relocalizer::Relocalize srv;
  srv.request.timeout = 0.5;
  const ros::WallTime start = ros::WallTime::now();
  ASSERT_TRUE(ros::service::call("/relocalizer/relocalize", srv));
  const double elapsed = (ros::WallTime::now() - start).toSec();
  EXPECT_FALSE(srv.response.success);
  EXPECT_TRUE(contains(srv.response.message, "no synchronised frame within 0.50 s")) << srv.response.message;
  EXPECT_GE(elapsed, 0.45);
  EXPECT_LT(elapsed, 2.0);
  EXPECT_TRUE(failureResult("no synchronised frame"));
  EXPECT_TRUE(warned("no synchronised frame"));
}

TEST(OnDemand, BadInputsFailWithTheirReasonAndTheNodeAnswersTheNextGoodFrame) {
  const FrameMessages good = (*g_frames)[3];
  struct Case {
    std::string name;
    std::function<void(FrameMessages&)> spoil;
    std::string reason;
  };
  const std::vector<Case> cases = {
      {"colour encoding", [](FrameMessages& f) { f.colour.encoding = "bayer_rggb8"; },
       "unsupported colour encoding 'bayer_rggb8'"},
      {"depth encoding", [](FrameMessages& f) { f.depth.encoding = "8UC1"; },
       "unsupported depth encoding '8UC1'"},
      {"depth size",
       [](FrameMessages& f) {
         f.depth.width /= 2;
         f.depth.height /= 2;
         f.depth.step /= 2;
         f.depth.data.resize(f.depth.step * f.depth.height);
       },
       "differ in size"},
      {"camera_info size", [](FrameMessages& f) { f.info.width = 640; }, "camera_info is for 640x240"},
      {"truncated colour", [](FrameMessages& f) { f.colour.data.resize(100); }, "holds 100 bytes"},
      {"unregistered depth", [](FrameMessages& f) { f.depth.header.frame_id = "camera_depth_optical_frame"; },
       "depth must be registered to colour"},
      {"zero focal length", [](FrameMessages& f) { f.info.K[0] = 0.0; }, "camera_info K is unusable"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    g_results->clear();
    FrameMessages bad = good;
    c.spoil(bad);
    const auto response = callWhilePublishing(sending(bad), 3.0);
    EXPECT_FALSE(response.success);
    EXPECT_TRUE(contains(response.message, c.reason)) << response.message;
    EXPECT_TRUE(failureResult(c.reason));
    EXPECT_TRUE(warned(c.reason));
  }
  {
    SCOPED_TRACE("missing camera_info");
    g_results->clear();
    const auto response = callWhilePublishing(sending(good, false), 1.5);
    EXPECT_FALSE(response.success);
    EXPECT_TRUE(contains(response.message, ", 0 on /camera/rgb/camera_info since the last")) << response.message;
    EXPECT_TRUE(failureResult("is every topic published?"));
    // The watchdog reports images that never synchronise even without a call.
    EXPECT_TRUE(warned("images arrive but no synchronised frame", 6.0));
  }
  const auto response = callWhilePublishing(sending(good), 5.0);
  expectAccurate(response, good.truth);
}

TEST(OnDemand, PoseWithinFiveCentimetresAndDegreesWithPoseAndTfPublished) {
  tf2_ros::Buffer& buffer = *g_tf;
  // map -> camera is sent once per answer: be connected to the node's /tf first.
  Listener<tf2_msgs::TFMessage> tf_topic("/tf");
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(10.0);
  while (!tf_topic.connected() && ros::WallTime::now() < give_up) ros::WallDuration(0.05).sleep();
  ros::WallDuration(0.5).sleep();
  for (size_t index : {0u, 9u, 19u}) {
    SCOPED_TRACE("test frame " + std::to_string(index));
    const FrameMessages& frame = (*g_frames)[index];
    const auto response = callWhilePublishing(sending(frame), 5.0);
    expectAccurate(response, frame.truth);
    if (!response.success) continue;
    const ros::Time stamp = response.pose.header.stamp;

    // ~pose is latched: a late subscriber gets the last successful pose.
    Listener<geometry_msgs::PoseWithCovarianceStamped> pose("/relocalizer/pose");
    auto latched = pose.waitFor([&](const auto& p) { return p.header.stamp == stamp; }, 5.0);
    ASSERT_TRUE(latched.has_value());
    EXPECT_EQ(latched->pose.pose.position.x, response.pose.pose.pose.position.x);
    // A real covariance, not the identity placeholder.
    EXPECT_GT(latched->pose.covariance[0], 0.0);
    EXPECT_LT(latched->pose.covariance[0], 1e-2);

    // Direct mode: map -> camera at the frame's stamp is the pose itself.
    geometry_msgs::TransformStamped tf;
    ASSERT_NO_THROW(tf = buffer.lookupTransform("map", kCameraFrame, stamp, ros::Duration(3.0)));
    const Pose from_tf = relocalizer_ros::fromTransformMsg(tf.transform);
    EXPECT_LT(relocalizer::translationError(from_tf, relocalizer_ros::fromPoseMsg(response.pose.pose.pose)), 1e-6);
    EXPECT_LT(relocalizer::translationError(from_tf, frame.truth), 0.05);
    EXPECT_LT(relocalizer::rotationErrorDegrees(from_tf, frame.truth), 5.0);
  }
}

TEST(OnDemand, ConcurrentCallsOnOneFrameGetTheSameAnswer) {
  FrameMessages frame = (*g_frames)[5];
  frame.stamp(ros::Time::now());
  // Publish once and let it become the latest frame.
  const auto first = callWhilePublishing([&] { g_camera->publish(frame); }, 5.0);
  ASSERT_TRUE(first.success) << first.message;
  std::vector<relocalizer::Relocalize> calls(3);
  std::vector<std::thread> threads;
  for (auto& call : calls) {
    call.request.timeout = 5.0;
    call.request.wait_for_next = false;
    threads.emplace_back([&call] { ros::service::call("/relocalizer/relocalize", call); });
  }
  for (auto& t : threads) t.join();
  for (const auto& call : calls) {
    ASSERT_TRUE(call.response.success) << call.response.message;
    EXPECT_EQ(call.response.pose.header.stamp, frame.colour.header.stamp);
    EXPECT_EQ(call.response.pose.pose.pose.position.x, calls[0].response.pose.pose.pose.position.x);
    EXPECT_EQ(call.response.pose.pose.pose.orientation.w, calls[0].response.pose.pose.pose.orientation.w);
  }
}

TEST(OnDemand, WaitForNextTimesOutWhenNoNewFrameComes) {
  relocalizer::Relocalize srv;
  srv.request.timeout = 0.3;
  srv.request.wait_for_next = true;
  const ros::WallTime start = ros::WallTime::now();
  ASSERT_TRUE(ros::service::call("/relocalizer/relocalize", srv));
  EXPECT_FALSE(srv.response.success);
  EXPECT_TRUE(contains(srv.response.message, "no new synchronised frame within 0.30 s")) << srv.response.message;
  EXPECT_LT((ros::WallTime::now() - start).toSec(), 1.5);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_on_demand");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  std::vector<FrameMessages> frames = loadFixtureFrames();
  CameraPublisher camera;
  Listener<ResultMsg> results("/relocalizer/result");
  Listener<rosgraph_msgs::Log> rosout("/rosout", 1000);
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  g_tf = &tf_buffer;
  g_frames = &frames;
  g_camera = &camera;
  g_results = &results;
  g_rosout = &rosout;
  const int code = RUN_ALL_TESTS();
  spinner.stop();
  return code;
}
