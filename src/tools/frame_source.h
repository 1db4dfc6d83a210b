#pragma once
// Where train and evaluate get their posed frames: a dataset folder
// (dataset.h) or a rosbag (src/ros/bag_dataset.h), behind one small interface
// and one set of command-line options, so both tools treat the two alike.

#include <memory>
#include <optional>
#include <string>

#include "../ros/bag_dataset.h"
#include "../ros/key_frames.h"
#include "dataset_arguments.h"
#include "relocalizer/core/id_ranges.h"
#include "relocalizer/data/frame_selection.h"

namespace relocalizer::cli {

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual size_t size() const = 0;
  virtual int id(size_t i) const = 0;
  virtual double stamp(size_t i) const = 0;
  virtual const std::optional<Pose>& groundTruth(size_t i) const = 0;
  virtual Expected<RgbdFrame> load(size_t i) const = 0;  // thread-safe
  virtual std::string summary() const = 0;
  // The folder or bag path as given.
  virtual const std::string& path() const = 0;
  // For the model header and summary.json: "7-Scenes folder", "rosbag (TF map -> camera)".
  virtual std::string formatDescription() const = 0;
  // 7-Scenes and 12-Scenes stamps are frame numbers.
  virtual bool integerStamps() const = 0;
  // The frames actually used, as a selection expression ("0-3,7,12-20").
  std::string usedIds() const {
    std::vector<int> ids;
    for (size_t i = 0; i < size(); ++i) ids.push_back(id(i));
    return formatIdRanges(ids);
  }
};

class DatasetSource : public FrameSource {
 public:
  DatasetSource(std::unique_ptr<Dataset> data, std::string path)
      : data_(std::move(data)), path_(std::move(path)) {}
  size_t size() const override { return data_->size(); }
  int id(size_t i) const override { return data_->id(i); }
  double stamp(size_t i) const override { return data_->stamp(i); }
  const std::optional<Pose>& groundTruth(size_t i) const override { return data_->groundTruth(i); }
  Expected<RgbdFrame> load(size_t i) const override { return data_->load(i); }
  std::string summary() const override { return data_->summary(); }
  const std::string& path() const override { return path_; }
  std::string formatDescription() const override { return formatName(data_->format()); }
  bool integerStamps() const override {
    return data_->format() == DatasetFormat::SevenScenesFolder ||
           data_->format() == DatasetFormat::SevenScenesScene ||
           data_->format() == DatasetFormat::TwelveScenes;
  }

 private:
  std::unique_ptr<Dataset> data_;
  std::string path_;
};

class BagSource : public FrameSource {
 public:
  explicit BagSource(std::unique_ptr<relocalizer_ros::BagDataset> bag) : bag_(std::move(bag)) {}
  size_t size() const override { return bag_->size(); }
  int id(size_t i) const override { return bag_->id(i); }
  double stamp(size_t i) const override { return bag_->stamp(i); }
  const std::optional<Pose>& groundTruth(size_t i) const override { return bag_->groundTruth(i); }
  Expected<RgbdFrame> load(size_t i) const override { return bag_->load(i); }
  std::string summary() const override { return bag_->summary(); }
  const std::string& path() const override { return bag_->path(); }
  std::string formatDescription() const override { return "rosbag (" + bag_->poseSource() + ")"; }
  bool integerStamps() const override { return false; }
  const relocalizer_ros::BagDataset& bag() const { return *bag_; }

 private:
  std::unique_ptr<relocalizer_ros::BagDataset> bag_;
};

// The options that choose the frames, shared by train and evaluate.
struct SourceOptions {
  std::string dataset, format = "auto", frames, split = "all";
  std::string bag, min_motion;
  relocalizer_ros::BagOptions bag_options;
  CLI::Option* dataset_option = nullptr;
  CLI::Option* bag_option = nullptr;

  void add(CLI::App& app, const std::string& dataset_help, const std::string& frames_help) {
    dataset_option = app.add_option("-d,--dataset", dataset, dataset_help);
    bag_option = app.add_option(
        "--bag", bag,
        "Rosbag with RGB-D topics and camera poses on /tf (or --pose-topic), e.g. recorded "
        "while a SLAM stack ran; instead of --dataset");
    dataset_option->excludes(bag_option);
    app.add_option("--format", format, "auto | 7scenes | 12scenes | tum (--dataset)")
        ->capture_default_str()
        ->excludes(bag_option);
    app.add_option("--frames", frames, frames_help);
    app.add_option("--split", split, "train | test | all (7-Scenes scenes)")
        ->capture_default_str()
        ->excludes(bag_option);
    auto& b = bag_options;
    const std::string group = "Rosbag (--bag)";
    const auto bag_only = [&](CLI::Option* option) { option->needs(bag_option)->group(group); };
    bag_only(app.add_option("--rgb-topic", b.rgb_topic, "Colour sensor_msgs/Image topic")
                 ->capture_default_str());
    bag_only(
        app.add_option("--depth-topic", b.depth_topic,
                       "Depth sensor_msgs/Image topic, registered to colour (16UC1 mm or 32FC1 m)")
            ->capture_default_str());
    bag_only(
        app.add_option("--camera-info-topic", b.camera_info_topic, "sensor_msgs/CameraInfo topic")
            ->capture_default_str());
    bag_only(app.add_option("--sync-tolerance", b.sync_tolerance,
                            "Largest colour-depth and colour-camera_info stamp difference, s")
                 ->capture_default_str());
    bag_only(app.add_option(
                    "--map-frame", b.map_frame,
                    "World frame of the model: TF lookups start here; a pose topic must be in it")
                 ->capture_default_str());
    bag_only(app.add_option("--camera-frame", b.camera_frame,
                            "Camera frame for TF lookups (default: the colour images' frame_id)"));
    bag_only(
        app.add_option("--pose-topic", b.pose_topic,
                       "Camera poses from this PoseStamped, PoseWithCovarianceStamped, Odometry or "
                       "TransformStamped topic instead of TF"));
    bag_only(app.add_option(
                    "--pose-tolerance", b.pose_tolerance,
                    "A frame has a pose when every pose stream it needs has samples at most this "
                    "many s before and after its stamp (interpolated); others are skipped")
                 ->capture_default_str());
    bag_only(
        app.add_option("--min-motion", min_motion,
                       "Key frames: keep a frame when it moved METRES or turned DEGREES since the "
                       "last kept one, e.g. 0.05,5 (default: every frame with a pose)"));
  }

  // After parsing: the opened source, or a one-line reason.
  Expected<std::unique_ptr<FrameSource>> open() {
    if (dataset.empty() == bag.empty())
      return makeError(dataset.empty() ? "one of --dataset or --bag is required"
                                       : "--dataset and --bag exclude each other");
    if (!bag.empty()) {
      bag_options.frames = frames;
      if (!min_motion.empty()) {
        auto motion = relocalizer_ros::parseMinMotion(min_motion);
        if (!motion) return makeError(motion.error());
        bag_options.min_translation = motion->first;
        bag_options.min_rotation_degrees = motion->second;
      }
      auto opened = relocalizer_ros::BagDataset::open(bag, bag_options);
      if (!opened) return makeError(opened.error());
      return std::unique_ptr<FrameSource>(new BagSource(std::move(*opened)));
    }
    auto opened = DatasetArguments{dataset, format, frames, split}.open();
    if (!opened) return makeError(opened.error());
    return std::unique_ptr<FrameSource>(new DatasetSource(std::move(*opened), dataset));
  }
};

}  // namespace relocalizer::cli
