#pragma once
// Learn mode's settings (learning_feed.h, docs/online_learning.md): the
// learn_* parameters as given, and as the learner takes them once checked.

#include <string>

#include "param_reading.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/online/submap_rule.h"

namespace relocalizer_ros {

struct LearnSettings {
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
  // A covered key frame is learned again where less than this share of its
  // depth lies on the covering submaps' surface (online/place_change.h).
  double learn_relearn_agreement = 0.9;
  // The learn_* settings as the learner takes them, read and checked by
  // readLearningParams (online_learner.h), the one check the tools share.
  relocalizer::LearningParams learning;
  // The learn_submap_*, learn_cover_steps and learn_relearn_agreement settings,
  // checked by submapParamsError.
  relocalizer::SubmapParams submaps;
};

// learn, save_on_exit, save_model_folder and the learn_* parameters; in learn
// mode also `learning` and `submaps` from them (reading learn_config).
void readLearnSettings(ParamReader& reader, LearnSettings& learn);

}  // namespace relocalizer_ros
