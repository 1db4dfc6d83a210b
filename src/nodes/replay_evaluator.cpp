// roslaunch relocalizer replay.launch model:=MODEL bag:=BAG [output:=DIR]
// runs this beside the node: see src/ros/replay/replay_evaluator.h.

#include <ros/ros.h>

#include "../ros/replay/replay_evaluator.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "replay_evaluator");
  ros::NodeHandle private_nh("~");
  relocalizer_ros::ReplayEvaluator::Options options;
  private_nh.param("bag", options.bag, options.bag);
  private_nh.param("play", options.play, options.play);
  private_nh.param("output", options.output, options.output);
  private_nh.param("model", options.model, options.model);
  private_nh.param("colour_topic", options.colour_topic, options.colour_topic);
  private_nh.param("depth_topic", options.depth_topic, options.depth_topic);
  private_nh.param("info_topic", options.info_topic, options.info_topic);
  private_nh.param("truth_topic", options.truth_topic, options.truth_topic);
  private_nh.param("node_timeout", options.node_timeout, options.node_timeout);
  private_nh.param("result_timeout", options.result_timeout, options.result_timeout);
  private_nh.param("idle_timeout", options.idle_timeout, options.idle_timeout);
  private_nh.param("rate", options.rate, options.rate);
  if (options.play && options.bag.empty()) {
    ROS_FATAL("replay: ~bag is not set (a bag written by make_bag), and ~play is true");
    return 2;
  }
  relocalizer_ros::ReplayEvaluator evaluator(ros::NodeHandle(), options);
  return evaluator.run();
}
