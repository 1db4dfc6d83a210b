#pragma once
// The node's parameters: one struct, one reader. The defaults here are the
// ones in config/default.yaml; a rostest checks that the two agree, so a
// rosrun without the launch file behaves like the documented configuration.

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/online/submap_rule.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer_ros {

// The longest a ~relocalize call may wait for a frame (longer asks wait this
// long), and so the bound of service_timeout: a waiting call holds a thread,
// and a caller that waits longer has long given up.
constexpr double kMaxServiceWaitSeconds = 60.0;

enum class Mode {
  OnDemand,   // keep the latest synchronised frame; relocalize on a service call
  Continuous  // relocalize incoming frames in a worker thread, up to max_rate
};

// One entry of the `places` parameter.
struct PlaceSpec {
  std::string name;
  std::string model;
  std::string map_frame;  // the node's map_frame when the entry names none
  // Why this place cannot be loaded, naming the parameter (a name or frame
  // the name rule refuses, core/outside_text.h); empty when it can. A place
  // refused is one place that does not load, not a node that cannot start.
  std::string refused;
};

struct NodeParams {
  std::string model;
  // The name of `model`'s place (learn: of the learned place); empty: the
  // model file's stem, or "learned" (placeName()).
  std::string place_name;
  std::vector<PlaceSpec> places;    // further places, as given
  std::string model_place_refused;  // as PlaceSpec::refused, for `model`'s place
  Mode mode = Mode::OnDemand;
  std::string map_frame = "map";
  std::string odom_frame;  // empty: publish map_frame -> camera frame
  bool publish_tf = true;
  double transform_tolerance = 0.1;  // seconds map -> odom is post-dated by
  double tf_rate = 10.0;             // Hz, map -> odom re-broadcast (0: only on updates)
  double tf_timeout = 0.2;           // seconds to wait for odom -> camera at the frame stamp
  bool approx_sync = true;
  int sync_queue_size = 5;
  double max_interval = 0.05;    // seconds between colour, depth and info stamps (0: no limit)
  double max_rate = 2.0;         // Hz, continuous mode (0: as fast as frames come)
  bool process_all = false;      // continuous mode: queue every frame instead of dropping
  double service_timeout = 2.0;  // seconds a call waits for a frame when it asks for <= 0
  double input_timeout =
      3.0;          // seconds of images without a synchronised frame before it is reported
  int threads = 0;  // TBB threads inside a relocalization (0: every core)
  // Pose hints (node_hints.h): seconds an `initialpose` hint holds for the
  // relocalizations after it, until one answers with a pose.
  double hint_timeout = 10.0;
  // Hand-off of accepted poses (pose_handoff.h).
  bool forward_initialpose = false;  // publish each accepted pose on initialpose (amcl, rtabmap)
  std::string set_pose_service;      // call this robot_localization SetPose service ("": none)
  std::string handoff_frame;         // hand off this frame's pose, not the camera's ("": camera)
  // Online learning beside SLAM (docs/online_learning.md).
  bool learn = false;        // learn the place from frames posed by TF map_frame -> camera
  std::string save_on_exit;  // learn: write the model and its key frames here at shutdown
  // learn: ~save_model writes only inside this folder ("": $ROS_HOME/relocalizer)
  std::string save_model_folder;
  std::string learn_min_motion = "0.05,5";  // key frames: metres,degrees since the last one
  int learn_max_keyframes = 64;             // cap on stored key frames, per submap
  int learn_first_retrain = 2;              // key frames before the first model
  double learn_retrain_growth = 0.25;       // retrain when the store grew by this share
  bool learn_surface_gate = false;          // learned models: refuse poses off the learned surface
  // The check of SLAM's poses against the key frames' images (slam_pose_check.h).
  bool learn_slam_check = true;
  std::string learn_max_slam_speed = "3,360";      // metres, degrees per second
  std::string learn_slam_disagreement = "0.05,5";  // metres, degrees
  std::string
      learn_config;  // training YAML (as `train --config`); empty: config/forest.yaml defaults
  // Submaps (online/submap_rule.h): metres from the active submap's key
  // frames that count as its area, key frames a full submap hands to the next,
  // key-frame steps within which a frozen submap's key frame covers a new one.
  double learn_submap_radius = 1.5;
  int learn_submap_overlap = 4;
  double learn_cover_steps = 1.0;
  // /diagnostics (node_diagnostics.h); inputs count as stopped after input_timeout.
  double diagnostic_period = 1.0;     // seconds between statuses (diagnostic_updater's name)
  int diagnostics_max_failures = 10;  // relocalized frames in a row without a pose: WARN (0: never)
  // The learn_* settings as the learner takes them, read and checked by
  // readLearningParams (online_learner.h), the one check the tools share.
  relocalizer::LearningParams learning;
  // The learn_submap_* and learn_cover_steps settings, checked by submapParamsError.
  relocalizer::SubmapParams submaps;
  relocalizer::RelocalizerParams relocalizer;
};

// Reads every parameter from the private node handle. A parameter of the wrong
// type, an unknown `relocalizer/` key or a value out of range is an error that
// names it, its value and the allowed range: a typo must not silently keep a
// default on a robot, nor a huge duration abort the node inside ros::Duration.
relocalizer::Expected<NodeParams> loadNodeParams(const ros::NodeHandle& private_nh);

// The places to load at start: `places`, then `model`'s place (not in learn
// mode, where `model` is the learned place's start).
std::vector<PlaceSpec> startupPlaces(const NodeParams& params);
// The name of `model`'s place, or of the learned place in learn mode.
std::string placeName(const NodeParams& params);
// Learn mode: `name` is placeName() or one of its submaps' (placeName()/i),
// names the learner owns.
bool isLearnedPlaceName(const NodeParams& params, const std::string& name);

// The parameters as JSON, keyed as in config/default.yaml, for the start-up
// log and for the test that compares the compiled defaults with that file.
std::string nodeParamsToJson(const NodeParams& params);

const char* modeName(Mode mode);

}  // namespace relocalizer_ros
