// rosrun relocalizer relocalizer_node _model:=MODEL: see src/ros/node/relocalizer_node.h.

#include <ros/ros.h>

#include "../ros/node/relocalizer_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "relocalizer");
  // Held here, not as temporaries: when the last NodeHandle dies roscpp shuts
  // down, rosconsole with it, and the reason below would never be printed.
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  auto node = relocalizer_ros::RelocalizerNode::create(nh, private_nh);
  if (!node) {
    ROS_FATAL("relocalizer: %s", node.error().c_str());
    return 1;
  }
  ros::spin();
  return 0;
}
