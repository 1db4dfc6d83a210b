#pragma once
// What the node rostests share: the fixture's frames as camera messages, a
// publisher for them, and listeners that wait for ~result and /rosout lines.

#include <cv_bridge/cv_bridge.h>
#include <gtest/gtest.h>
#include <relocalizer/Relocalize.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <relocalizer/RelocalizationResult.h>
#include "../../src/ros/conversion/message_conversion.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/data/dataset.h"

namespace relocalizer_test {

using relocalizer::Pose;
using ResultMsg = relocalizer::RelocalizationResult;

constexpr const char* kCameraFrame = "camera_rgb_optical_frame";

struct FrameMessages {
  sensor_msgs::Image colour;
  sensor_msgs::Image depth;
  sensor_msgs::CameraInfo info;
  Pose truth = Pose::Identity();

  void stamp(const ros::Time& time) {
    colour.header.stamp = depth.header.stamp = info.header.stamp = time;
  }
};

inline sensor_msgs::Image imageMessage(const cv::Mat& mat, const std::string& encoding) {
  return *cv_bridge::CvImage(std_msgs::Header(), encoding, mat).toImageMsg();
}

// The test frames (or `split` train) of a fixture room (make_fixture.sh:
// `scene`, and `scene2` for the second place), as a camera driver would send
// them: bgr8 colour, 16UC1 millimetre depth, camera_info.
inline std::vector<FrameMessages> loadFixtureFrames(const std::string& scene = "scene",
                                                    const std::string& split = "test") {
  std::string fixture;
  ros::NodeHandle("~").getParam("fixture", fixture);
  auto dataset = relocalizer::openDataset(fixture + "/" + scene + "/" + split);
  if (!dataset) throw std::runtime_error(dataset.error());
  std::vector<FrameMessages> frames;
  for (size_t i = 0; i < (*dataset)->size(); ++i) {
    auto frame = (*dataset)->load(i);
    if (!frame) throw std::runtime_error(frame.error());
    FrameMessages m;
    m.colour = imageMessage(frame->colour, sensor_msgs::image_encodings::BGR8);
    m.depth = imageMessage(relocalizer::depthToMillimetres(frame->depth),
                           sensor_msgs::image_encodings::TYPE_16UC1);
    m.colour.header.frame_id = m.depth.header.frame_id = kCameraFrame;
    m.info.header.frame_id = kCameraFrame;
    m.info.width = frame->camera.width;
    m.info.height = frame->camera.height;
    m.info.K = {
        frame->camera.fx, 0, frame->camera.cx, 0, frame->camera.fy, frame->camera.cy, 0, 0, 1};
    m.truth = *frame->ground_truth;
    frames.push_back(std::move(m));
  }
  return frames;
}

// Publishes on the topics the test launch files remap the node's inputs to.
class CameraPublisher {
 public:
  CameraPublisher() {
    ros::NodeHandle nh;
    colour_ = nh.advertise<sensor_msgs::Image>("/camera/rgb/image_raw", 5);
    depth_ = nh.advertise<sensor_msgs::Image>("/camera/depth/image_raw", 5);
    info_ = nh.advertise<sensor_msgs::CameraInfo>("/camera/rgb/camera_info", 5);
  }
  // Waits until the node listens, so no test message is lost to connection set-up.
  bool waitForNode(double seconds = 30.0) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
    while (ros::ok() && ros::WallTime::now() < end) {
      if (colour_.getNumSubscribers() && depth_.getNumSubscribers() && info_.getNumSubscribers())
        return true;
      ros::WallDuration(0.05).sleep();
    }
    return false;
  }
  void publish(const FrameMessages& frame, bool with_info = true) {
    if (with_info) info_.publish(frame.info);
    depth_.publish(frame.depth);
    colour_.publish(frame.colour);
  }

 private:
  ros::Publisher colour_, depth_, info_;
};

// Keeps every message of a topic and waits for one that matches.
template <typename M>
class Listener {
 public:
  explicit Listener(const std::string& topic, uint32_t queue = 100) {
    sub_ = ros::NodeHandle().subscribe<M>(topic, queue, [this](const typename M::ConstPtr& msg) {
      std::lock_guard<std::mutex> lock(mutex_);
      messages_.push_back(*msg);
    });
  }
  std::optional<M> waitFor(const std::function<bool(const M&)>& match, double seconds) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
    while (ros::ok() && ros::WallTime::now() < end) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        for (const M& m : messages_)
          if (match(m)) return m;
      }
      ros::WallDuration(0.02).sleep();
    }
    return std::nullopt;
  }
  std::vector<M> messages() {
    std::lock_guard<std::mutex> lock(mutex_);
    return messages_;
  }
  void clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    messages_.clear();
  }
  bool connected() const { return sub_.getNumPublishers() > 0; }

 private:
  ros::Subscriber sub_;
  std::mutex mutex_;
  std::vector<M> messages_;
};

inline bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// A relocalize call made while `publish` runs every 0.1 s in another thread:
// with wait_for_next the call only takes frames sent after it started.
// `request` as given (a hint, for one).
inline relocalizer::Relocalize::Response callWhilePublishing(
    const std::function<void()>& publish, const relocalizer::Relocalize::Request& request) {
  relocalizer::Relocalize srv;
  srv.request = request;
  std::atomic<bool> done{false};
  std::thread publisher([&] {
    while (!done && ros::ok()) {
      publish();
      ros::WallDuration(0.1).sleep();
    }
  });
  const bool called = ros::service::call("/relocalizer/relocalize", srv);
  done = true;
  publisher.join();
  EXPECT_TRUE(called) << "the service call itself failed";
  return srv.response;
}
inline relocalizer::Relocalize::Response callWhilePublishing(const std::function<void()>& publish,
                                                             double timeout,
                                                             bool wait_for_next = true) {
  relocalizer::Relocalize::Request request;
  request.timeout = timeout;
  request.wait_for_next = wait_for_next;
  return callWhilePublishing(publish, request);
}

inline double translationError(const geometry_msgs::Pose& estimate, const Pose& truth) {
  return relocalizer::translationError(relocalizer_ros::fromPoseMsg(estimate), truth);
}
inline double rotationError(const geometry_msgs::Pose& estimate, const Pose& truth) {
  return relocalizer::rotationErrorDegrees(relocalizer_ros::fromPoseMsg(estimate), truth);
}

}  // namespace relocalizer_test
