#pragma once
// The learn-mode rostests' SLAM run: the fixture room's training frames with
// their poses on TF (map -> odom -> camera), as a SLAM system publishes them
// (make_fixture.sh writes learn.bag); then frames without TF.

#include <relocalizer/SaveModel.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2_msgs/TFMessage.h>

#include <functional>
#include <optional>

#include "node_test_support.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/submap_folder.h"

namespace relocalizer_test {

// What SLAM's TF says of frame `index` (from 0): as recorded, or changed by
// a test of SLAM that lies.
using SlamTf = std::function<void(tf2_msgs::TFMessage& message, int index)>;

// Plays the bag as `rosbag play` would (same topics, same pacing), once the
// node listens, so no frame is lost to connection set-up. Returns the number
// of frames played.
inline int playLearnBag(CameraPublisher& camera, const SlamTf& slam_tf = {}) {
  std::string fixture;
  ros::NodeHandle("~").getParam("fixture", fixture);
  ros::NodeHandle nh;
  ros::Publisher tf = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
  ros::Publisher colour = nh.advertise<sensor_msgs::Image>("/camera/rgb/image_raw", 100);
  ros::Publisher depth = nh.advertise<sensor_msgs::Image>("/camera/depth/image_raw", 100);
  ros::Publisher info = nh.advertise<sensor_msgs::CameraInfo>("/camera/rgb/camera_info", 100);
  EXPECT_TRUE(camera.waitForNode());
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(10.0);
  while (tf.getNumSubscribers() == 0 && ros::WallTime::now() < give_up)
    ros::WallDuration(0.05).sleep();
  ros::WallDuration(0.5).sleep();
  rosbag::Bag bag(fixture + "/learn.bag");
  rosbag::View view(bag);
  int frames = 0, tf_messages = 0;
  ros::Time previous;
  for (const rosbag::MessageInstance& m : view) {
    if (!previous.isZero() && m.getTime() > previous) (m.getTime() - previous).sleep();
    previous = m.getTime();
    if (auto msg = m.instantiate<tf2_msgs::TFMessage>()) {
      tf2_msgs::TFMessage message = *msg;
      if (slam_tf) slam_tf(message, tf_messages);
      ++tf_messages;
      tf.publish(message);
    }
    if (m.getTopic() == "/camera/rgb/image_raw") {
      colour.publish(*m.instantiate<sensor_msgs::Image>());
      ++frames;
    }
    if (m.getTopic() == "/camera/depth/image_raw")
      depth.publish(*m.instantiate<sensor_msgs::Image>());
    if (m.getTopic() == "/camera/rgb/camera_info")
      info.publish(*m.instantiate<sensor_msgs::CameraInfo>());
  }
  // The publishers go with this scope; let the last frame's messages leave first.
  ros::WallDuration(0.5).sleep();
  return frames;
}

// Relocalizes `frame` without TF (tracking lost), retried until a learned
// place answers or `give_up`: a young model may lack the evidence for a view.
inline relocalizer::Relocalize::Response relocalizeUntilAnswered(CameraPublisher& camera,
                                                                 FrameMessages frame,
                                                                 const ros::WallTime& give_up) {
  relocalizer::Relocalize::Response response;
  do {
    response = callWhilePublishing(
        [&] {
          frame.stamp(ros::Time::now());
          camera.publish(frame);
        },
        5.0);
  } while (!response.success && ros::WallTime::now() < give_up);
  return response;
}

// The ~result of one more relocalization of `frame`: the node's figures now.
inline std::optional<ResultMsg> resultOfOneCall(CameraPublisher& camera,
                                                Listener<ResultMsg>& results, FrameMessages frame) {
  results.clear();
  callWhilePublishing(
      [&] {
        frame.stamp(ros::Time::now());
        camera.publish(frame);
      },
      5.0);
  return results.waitFor([](const ResultMsg&) { return true; }, 5.0);
}

// A save as ~save_model answered it: the folder it wrote and its manifest.
struct SavedFolder {
  std::string path;
  relocalizer::SubmapManifest manifest;
};

// Calls ~save_model with `path` (a folder inside the node's save_model_folder,
// as a user names it) and reads back the folder the answer says it wrote:
// its manifest, each named model loading (gtest failures say what did not).
inline std::optional<SavedFolder> saveAndReadFolder(const std::string& path) {
  relocalizer::SaveModel save;
  save.request.path = path;
  if (!ros::service::call("/relocalizer/save_model", save)) {
    ADD_FAILURE() << "~save_model could not be called";
    return std::nullopt;
  }
  EXPECT_TRUE(save.response.success) << save.response.message;
  const std::string& message = save.response.message;
  if (message.rfind("wrote /", 0) != 0 || message.find(" (") == std::string::npos) {
    ADD_FAILURE() << "~save_model answered: " << message;
    return std::nullopt;
  }
  const std::string written = message.substr(6, message.find(" (") - 6);
  auto manifest = relocalizer::readSubmapManifest(written);
  if (!manifest) {
    ADD_FAILURE() << manifest.error();
    return std::nullopt;
  }
  for (const relocalizer::SubmapEntry& entry : manifest->submaps) {
    if (entry.model.empty()) continue;  // an active submap saved before its first retrain
    auto model = relocalizer::loadModel(written + "/" + entry.model);
    EXPECT_TRUE(model.ok()) << (model.ok() ? "" : model.error());
  }
  return SavedFolder{written, *manifest};
}

}  // namespace relocalizer_test
