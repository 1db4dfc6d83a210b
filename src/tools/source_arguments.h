#pragma once
// The options that choose a tool's posed frames: a dataset folder
// (dataset_arguments.h) or a rosbag with its topics and pose source, opened
// by the one factory (src/ros/bag/frame_sources.h). Tools with these options link
// relocalizer_bag.

#include <memory>
#include <string>

#include "../ros/bag/frame_sources.h"
#include "dataset_arguments.h"

namespace relocalizer::cli {

struct SourceOptions : DatasetArguments {
  std::string bag, min_motion;
  relocalizer_ros::BagOptions bag_options;
  Option* bag_option = nullptr;

  void add(App& app, const std::string& dataset_help, const std::string& frames_help) {
    DatasetArguments::add(app, dataset_help, frames_help, /*required=*/false);
    bag_option = app.addOption(
        "--bag", bag,
        "Rosbag with RGB-D topics and camera poses on /tf (or --pose-topic), e.g. recorded "
        "while a SLAM stack ran; instead of --dataset");
    path_option->excludes(bag_option);
    format_option->excludes(bag_option);
    split_option->excludes(bag_option);
    addBagOptions(app, bag_option, bag_options, min_motion);
  }

  // The topic, pose and key-frame options of a bag, needing `bag_option`
  // (nullptr: a tool with several bag options, any of which they apply to).
  static void addBagOptions(App& app, Option* bag_option, relocalizer_ros::BagOptions& b,
                            std::string& min_motion) {
    const std::string group = "Rosbag (--bag)";
    const auto bag_only = [&](Option* option) {
      if (bag_option) option->needs(bag_option);
      option->group(group);
    };
    bag_only(
        app.addOption("--rgb-topic", b.rgb_topic, "Colour sensor_msgs/Image topic")->showDefault());
    bag_only(
        app.addOption("--depth-topic", b.depth_topic,
                      "Depth sensor_msgs/Image topic, registered to colour (16UC1 mm or 32FC1 m)")
            ->showDefault());
    bag_only(
        app.addOption("--camera-info-topic", b.camera_info_topic, "sensor_msgs/CameraInfo topic")
            ->showDefault());
    bag_only(app.addOption("--sync-tolerance", b.sync_tolerance,
                           "Largest colour-depth and colour-camera_info stamp difference, s")
                 ->showDefault());
    bag_only(
        app.addOption("--map-frame", b.map_frame,
                      "World frame of the model: TF lookups start here; a pose topic must be in it")
            ->showDefault());
    bag_only(app.addOption("--camera-frame", b.camera_frame,
                           "Camera frame for TF lookups (default: the colour images' frame_id)"));
    bag_only(
        app.addOption("--pose-topic", b.pose_topic,
                      "Camera poses from this PoseStamped, PoseWithCovarianceStamped, Odometry or "
                      "TransformStamped topic instead of TF"));
    bag_only(
        app.addOption("--pose-tolerance", b.pose_tolerance,
                      "A frame has a pose when every pose stream it needs has samples at most this "
                      "many s before and after its stamp (interpolated); others are skipped")
            ->showDefault());
    bag_only(
        app.addOption("--min-motion", min_motion,
                      "Key frames: keep a frame when it moved METRES or turned DEGREES since the "
                      "last kept one, e.g. 0.05,5 (default: every frame with a pose)"));
  }

  // After parsing: the opened source, or a one-line reason.
  Expected<std::unique_ptr<FrameSource>> open(bool register_colour = true) const {
    return open(path, bag, register_colour);
  }

  // The same selection and bag options applied to another folder or bag.
  Expected<std::unique_ptr<FrameSource>> open(const std::string& folder,
                                              const std::string& bag_path,
                                              bool register_colour = true) const {
    relocalizer_ros::FrameSourceRequest request;
    auto folder_options = options(register_colour);
    if (!folder_options) return makeError(folder_options.error());
    request.dataset = folder;
    request.dataset_options = *folder_options;
    request.bag = bag_path;
    request.bag_options = bag_options;
    request.bag_options.frames = frames;
    request.min_motion = min_motion;
    return relocalizer_ros::openFrameSource(request);
  }
};

}  // namespace relocalizer::cli
