#pragma once
// Rosbag replay evaluation: plays a bag through a running relocalizer node and
// scores the node's ~result against the bag's ground truth with the same
// summary, table and files as the offline `evaluate` tool.
//
// In play mode the evaluator is the player: it publishes one frame (colour,
// depth, camera_info and ground truth with one stamp, as make_bag writes them),
// waits for the node's result for that stamp, then publishes the next. The
// replay is therefore exact (no frame is dropped, whatever the machine's speed)
// and as fast as the node, which with the node's process_all makes its
// accuracy that of `evaluate` on the same frames. With `rate` > 0 it is a
// camera instead: it publishes on a fixed schedule (rate Hz) without waiting,
// so a busy node drops frames as it would live, and it measures each answer's
// latency, from publishing the frame to receiving its ~result (stamp to
// publish, plus one local hop), and the share of frames answered. In collect mode it only
// listens, for use with `rosbag play` or a live camera, and finishes after
// idle_timeout seconds without messages.

#include <geometry_msgs/PoseStamped.h>
#include <ros/ros.h>

#include <condition_variable>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include <relocalizer/RelocalizationResult.h>
#include "relocalizer/eval/evaluation.h"

namespace rosbag {
class Bag;
}
namespace relocalizer {
class ProgressBar;
}

namespace relocalizer_ros {

class ReplayEvaluator {
 public:
  struct Options {
    std::string bag;     // play mode: the bag to play
    bool play = true;    // false: collect only
    std::string output;  // folder for poses.txt, errors.csv, summary.json, plots ("" = none)
    std::string model;   // recorded in summary.json
    std::string colour_topic = "/camera/rgb/image_raw";
    std::string depth_topic = "/camera/depth/image_raw";
    std::string info_topic = "/camera/rgb/camera_info";
    std::string truth_topic = "/ground_truth/pose";
    std::string dataset_topic = "/dataset/info";
    double node_timeout = 60.0;    // seconds to wait for the node to subscribe
    double result_timeout = 60.0;  // seconds to wait for the answer to one frame
    double idle_timeout = 10.0;    // collect mode: seconds without messages that end it
    double rate = 0.0;             // play mode: > 0 paces frames at this many Hz (no waiting)
  };

  ReplayEvaluator(ros::NodeHandle nh, Options options);
  // Runs to the end and returns the process exit code: 0 when the table was
  // printed (and the files written), 1 when the replay or the writing failed,
  // 2 for unusable input.
  int run();

 private:
  using ResultMsg = relocalizer::RelocalizationResult;

  struct Truth {
    int id = -1;
    ros::Time stamp;
    relocalizer::Pose pose;
  };

  // Play mode, in its steps: the frames' publishers, one frame's messages as
  // read from the bag, and what the replay counted.
  struct FramePublishers {
    ros::Publisher colour, depth, info, truth;
  };
  struct FrameGroup;
  struct PlayCounts {
    int published = 0;   // complete frames sent to the node
    int incomplete = 0;  // skipped: colour, depth and camera_info without one stamp
    int unanswered = 0;  // sent, and no ~result came back
  };

  int play();
  // False (after a fatal log) when no node listens and answers within node_timeout.
  bool waitForNode(const FramePublishers& publishers);
  // Plays every frame of the bag; false when ROS shuts down.
  bool playFrames(rosbag::Bag& bag, const FramePublishers& publishers, std::vector<Truth>& truths,
                  PlayCounts& counts);
  // Publishes one frame and waits for its answer (or, paced, for its slot);
  // false when ROS shuts down. Empties `group`.
  bool publishFrame(FrameGroup& group, const FramePublishers& publishers,
                    relocalizer::ProgressBar& bar, ros::WallTime& next_slot,
                    std::vector<Truth>& truths, PlayCounts& counts);
  // Paced mode: waits for the answers still on their way and counts the missing ones.
  void waitForLastAnswers(PlayCounts& counts);
  int collect();
  int report(const std::vector<Truth>& truths);
  // Paced mode: answered share and latency percentiles, printed and (with
  // an output folder) written to latency.json.
  void reportLatency(int published);
  void onResult(const ResultMsg::ConstPtr& result);
  void onTruth(const geometry_msgs::PoseStamped::ConstPtr& truth);

  ros::NodeHandle nh_;
  const Options options_;
  ros::Subscriber result_sub_;

  std::mutex mutex_;
  std::condition_variable result_arrived_;
  std::map<ros::Time, ResultMsg> results_;           // first answer per frame stamp
  std::map<ros::Time, ros::WallTime> answered_at_;   // when that answer arrived
  std::map<ros::Time, ros::WallTime> published_at_;  // paced mode: when the frame went out
  std::vector<Truth> collected_truths_;              // collect mode
  nlohmann::json dataset_info_;                      // from make_bag, when present
  ros::WallTime last_message_;
};

}  // namespace relocalizer_ros
