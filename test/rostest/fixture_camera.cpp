// A fake RGB-D camera for the rostests: publishes the fixture's test frames in
// a loop at ~rate Hz, stamped with the current time.

#include "node_test_support.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "fixture_camera");
  ros::NodeHandle private_nh("~");
  double rate = 10.0;
  private_nh.param("rate", rate, rate);
  std::vector<relocalizer_test::FrameMessages> frames = relocalizer_test::loadFixtureFrames();
  relocalizer_test::CameraPublisher camera;
  ros::Rate loop(rate);
  for (size_t i = 0; ros::ok(); i = (i + 1) % frames.size()) {
    frames[i].stamp(ros::Time::now());
    camera.publish(frames[i]);
    loop.sleep();
  }
  return 0;
}
