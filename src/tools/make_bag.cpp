// make_bag: writes a dataset's frames as a rosbag a camera driver would have
// recorded, with the ground truth beside it, so the node can be replayed and
// evaluated on any dataset the core can read.

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseStamped.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <std_msgs/String.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "../ros/conversion/message_conversion.h"
#include "dataset_arguments.h"
#include "relocalizer/core/progress.h"
#include "relocalizer/core/version.h"
#include "relocalizer/data/tum_trajectory.h"

using namespace relocalizer;

namespace {

// Synthesized stamps start here rather than at 0, which ROS reads as "no time"
// (and tf2 as "latest").
constexpr double kSynthesizedStart = 1.0;

sensor_msgs::CameraInfo cameraInfoMsg(const CameraIntrinsics& camera,
                                      const std_msgs::Header& header) {
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = static_cast<uint32_t>(camera.width);
  info.height = static_cast<uint32_t>(camera.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);  // the readers return undistorted pinhole frames
  info.K = {camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {camera.fx, 0, camera.cx, 0, 0, camera.fy, camera.cy, 0, 0, 0, 1, 0};
  return info;
}

geometry_msgs::PoseStamped poseMsg(const Pose& pose, const std_msgs::Header& header) {
  geometry_msgs::PoseStamped msg;
  msg.header = header;
  msg.pose = relocalizer_ros::toPoseMsg(pose);
  return msg;
}

// Where --tf puts odom in the map: not the identity, so a consumer that mixes
// up map and odom, or composes the chain the wrong way round, is caught.
Pose mapToOdom() {
  Pose pose = Pose::Identity();
  pose.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(0.5, -0.3, 0.1);
  return pose;
}

geometry_msgs::TransformStamped transformMsg(const Pose& pose, const ros::Time& stamp,
                                             const std::string& parent, const std::string& child) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform = relocalizer_ros::toTransformMsg(pose);
  return t;
}

// What the bag is written with, as the options give it.
struct BagSettings {
  std::string output, depth_encoding = "16UC1", frame_id = "camera_rgb_optical_frame",
                      compression = "lz4";
  double rate = 0.0;
  bool tf = false;
  bool synthesize = false;  // stamps at `rate` rather than the dataset's
  // --tf-trajectory: TF from these poses at their own stamps instead of at the frames'.
  std::string tf_trajectory;
  std::vector<TrajectorySample> trajectory;
};

// A frame id, or a trajectory stamp on the dataset's clock (id / rate), as a
// synthesized stamp: ids count from `origin`, the first id of frames and
// trajectory together, at kSynthesizedStart.
ros::Time synthesizedStamp(double id, double origin, double rate) {
  return ros::Time(kSynthesizedStart + (id - origin) / rate);
}

// A trajectory stamp as a frame id of the synthesized clock: exactly the
// frame's where it is one to a thousandth of a frame (synthesize's
// walk_poses.txt writes tick / rate to microseconds), so TF and images share
// stamps.
double trajectoryId(double stamp, double rate) {
  const double id = stamp * rate;
  return std::abs(id - std::round(id)) < 1e-3 ? std::round(id) : id;
}

// /dataset/info: where the frames came from and how they were written.
nlohmann::json sourceInfo(const cli::DatasetArguments& arguments, const Dataset& data,
                          const BagSettings& settings, bool numbered) {
  const bool synthesize = settings.synthesize;
  nlohmann::json info = {{"dataset", arguments.path},
                         {"format", formatName(data.format())},
                         {"frames", arguments.frames},
                         {"split", arguments.split},
                         {"frame_count", data.size()},
                         {"stamps", synthesize ? "synthesized" : "dataset"},
                         {"rate", synthesize ? settings.rate : 0.0},
                         {"integer_stamps", numbered},
                         {"depth_encoding", settings.depth_encoding},
                         {"frame_id", settings.frame_id},
                         {"software_version", kSoftwareVersion}};
  if (!settings.tf_trajectory.empty()) info["tf_trajectory"] = settings.tf_trajectory;
  return info;
}

// The camera at `pose` in the map on /tf, as a SLAM system with odometry publishes it.
void writeTf(rosbag::Bag& bag, const Pose& pose, const ros::Time& stamp,
             const BagSettings& settings) {
  tf2_msgs::TFMessage message;
  message.transforms.push_back(transformMsg(mapToOdom(), stamp, "map", "odom"));
  message.transforms.push_back(
      transformMsg(mapToOdom().inverse() * pose, stamp, "odom", settings.frame_id));
  bag.write("/tf", stamp, message);
}

// One frame's messages under `header` (its stamp, id and frame id): the ground
// truth (and with --tf but no --tf-trajectory its TF), camera_info, depth,
// colour. True when it had ground truth.
bool writeFrame(rosbag::Bag& bag, const std_msgs::Header& header, const RgbdFrame& frame,
                const std::optional<Pose>& truth, const BagSettings& settings) {
  if (truth) {
    std_msgs::Header truth_header = header;
    truth_header.frame_id = "map";
    bag.write("/ground_truth/pose", header.stamp, poseMsg(*truth, truth_header));
    if (settings.tf && settings.tf_trajectory.empty()) writeTf(bag, *truth, header.stamp, settings);
  }
  bag.write("/camera/rgb/camera_info", header.stamp, cameraInfoMsg(frame.camera, header));
  // REP 118: 16UC1 millimetres with 0 for no reading, or 32FC1 metres with NaN.
  const cv_bridge::CvImage depth =
      settings.depth_encoding == "16UC1"
          ? cv_bridge::CvImage(header, sensor_msgs::image_encodings::TYPE_16UC1,
                               depthToMillimetres(frame.depth))
          : cv_bridge::CvImage(header, sensor_msgs::image_encodings::TYPE_32FC1, frame.depth);
  bag.write("/camera/depth/image_raw", header.stamp, *depth.toImageMsg());
  bag.write(
      "/camera/rgb/image_raw", header.stamp,
      *cv_bridge::CvImage(header, sensor_msgs::image_encodings::BGR8, frame.colour).toImageMsg());
  return truth.has_value();
}

Pose poseOf(const TrajectorySample& sample) {
  return poseFromTranslationQuaternion(sample.translation, sample.rotation);
}

void printWritten(const BagSettings& settings, int written, int with_truth, double elapsed) {
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(settings.output, ec);
  char stamps[64];
  if (settings.synthesize)
    std::snprintf(stamps, sizeof(stamps), "synthesized at %g Hz", settings.rate);
  else
    std::snprintf(stamps, sizeof(stamps), "from the dataset");
  std::printf(
      "wrote %d frames (%d with ground truth, depth %s, stamps %s) to %s (%.1f MB) in %.1f s\n",
      written, with_truth, settings.depth_encoding.c_str(), stamps, settings.output.c_str(),
      ec ? 0.0 : static_cast<double>(bytes) / 1e6, elapsed);
  if (!settings.trajectory.empty())
    std::printf("and /tf at each of the %zu poses of %s\n", settings.trajectory.size(),
                settings.tf_trajectory.c_str());
}

// The options into `arguments` and `settings`; the returned --rate option says
// whether a rate was given.
cli::Option* addOptions(cli::App& app, cli::DatasetArguments& arguments, BagSettings& settings) {
  arguments.add(app, "Dataset folder (7-Scenes, 12-Scenes, TUM, synthetic)",
                "Frame ids to write, e.g. 100-199,300-399 (default: all)");
  app.addOption("-o,--output", settings.output, "Bag file to write (replaced if it exists)")
      ->required();
  auto* rate =
      app.addOption("--rate", settings.rate, "Synthesize stamps at this many frames per second")
          ->range(0.001, 10000.0);
  app.addOption("--depth-encoding", settings.depth_encoding, "16UC1 (millimetres) | 32FC1 (metres)")
      ->oneOf({"16UC1", "32FC1"})
      ->showDefault();
  app.addOption("--frame-id", settings.frame_id, "frame_id of the colour and depth images")
      ->showDefault();
  app.addFlag("--tf", settings.tf,
              "Also write the ground truth on /tf as a SLAM system with odometry publishes it: "
              "map -> odom (fixed, not the identity) and odom -> FRAME_ID at each frame's stamp");
  app.addOption("--tf-trajectory", settings.tf_trajectory,
                "With --tf: write /tf at every pose of this TUM trajectory file (timestamp tx "
                "ty tz qx qy qz qw), frames or not, instead of at the frames, as SLAM keeps "
                "tracking between images (synthesize --rooms writes walk/walk_poses.txt, a "
                "pose at every tick of the walk, corridor included). With synthesized stamps "
                "the file's stamps are on the dataset's clock, frame id / --rate, and the bag "
                "starts at the earlier of the first frame and the first pose")
      ->existingFile();
  app.addOption("--compression", settings.compression, "none | lz4 | bz2")
      ->oneOf({"none", "lz4", "bz2"})
      ->showDefault();
  return rate;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Writes the selected frames of a dataset as a rosbag: /camera/rgb/image_raw (bgr8), "
      "/camera/depth/image_raw (16UC1 millimetres or 32FC1 metres, registered to colour), "
      "/camera/rgb/camera_info, the camera-to-world ground truth on /ground_truth/pose "
      "(PoseStamped, frame map), with --tf also on /tf, and a JSON description of the source on "
      "/dataset/info. Every "
      "header carries the frame's stamp and its dataset id as seq. Stamps are the dataset's, "
      "or synthesized at --rate (7-Scenes and 12-Scenes stamps are frame numbers, so they are "
      "synthesized at 30 Hz unless --rate says otherwise).",
      "make_bag"};
  cli::DatasetArguments arguments;
  BagSettings settings;
  const cli::Option* rate_option = addOptions(app, arguments, settings);
  if (const cli::Exit done = app.parse(argc, argv)) return *done;
  if (settings.frame_id.empty() || settings.frame_id[0] == '/')
    return cli::fail(app, "--frame-id must be a non-empty tf2 frame id without a leading slash");

  if (!settings.tf_trajectory.empty() && !settings.tf)
    return cli::fail(app, "--tf-trajectory needs --tf");

  auto opened = arguments.open();
  if (!opened) return cli::fail(app, opened.error());
  const Dataset& data = **opened;
  if (!settings.tf_trajectory.empty()) {
    auto trajectory = readTumTrajectory(settings.tf_trajectory);
    if (!trajectory) return cli::fail(app, "--tf-trajectory: " + trajectory.error());
    if (trajectory->empty())
      return cli::fail(app, "--tf-trajectory: " + settings.tf_trajectory + " holds no pose");
    settings.trajectory = std::move(*trajectory);
  }

  // 7-Scenes and 12-Scenes "stamps" are frame numbers; played as seconds they
  // would be a 1 Hz camera.
  const bool numbered = data.format() != DatasetFormat::Tum;
  settings.synthesize = *rate_option || numbered;
  if (!*rate_option) settings.rate = 30.0;
  std::printf("%s\n", data.summary().c_str());
  double origin = data.size() > 0 ? data.id(0) : 0.0;
  if (settings.synthesize && !settings.trajectory.empty())
    origin = std::min(origin, trajectoryId(settings.trajectory.front().stamp, settings.rate));
  const auto trajectoryStamp = [&](const TrajectorySample& sample) {
    return settings.synthesize
               ? synthesizedStamp(trajectoryId(sample.stamp, settings.rate), origin, settings.rate)
               : ros::Time(sample.stamp);
  };
  if (!settings.synthesize && !settings.trajectory.empty() &&
      settings.trajectory.front().stamp <= 0)
    return cli::fail(app, "--tf-trajectory: stamps must be positive with the dataset's stamps");

  const auto start = std::chrono::steady_clock::now();
  int written = 0, with_truth = 0;
  try {
    rosbag::Bag bag(settings.output, rosbag::bagmode::Write);
    if (settings.compression == "lz4") bag.setCompression(rosbag::compression::LZ4);
    if (settings.compression == "bz2") bag.setCompression(rosbag::compression::BZ2);

    std_msgs::String info_msg;
    info_msg.data = sourceInfo(arguments, data, settings, numbered).dump();
    ProgressBar bar("writing", data.size());
    size_t next_pose = 0;  // of the trajectory: TF written in stamp order among the frames
    for (size_t i = 0; i < data.size(); ++i) {
      bar.advance();
      auto frame = data.load(i);
      if (!frame) return cli::fail(app, frame.error());
      // Ids, not indices, so a selection with gaps keeps its gaps in time.
      std_msgs::Header header;
      header.seq = static_cast<uint32_t>(data.id(i));
      header.stamp = settings.synthesize ? synthesizedStamp(data.id(i), origin, settings.rate)
                                         : ros::Time(data.stamp(i));
      header.frame_id = settings.frame_id;
      if (i == 0) bag.write("/dataset/info", header.stamp, info_msg);
      for (; next_pose < settings.trajectory.size() &&
             trajectoryStamp(settings.trajectory[next_pose]) <= header.stamp;
           ++next_pose)
        writeTf(bag, poseOf(settings.trajectory[next_pose]),
                trajectoryStamp(settings.trajectory[next_pose]), settings);
      with_truth += writeFrame(bag, header, *frame, data.groundTruth(i), settings);
      ++written;
    }
    for (; next_pose < settings.trajectory.size(); ++next_pose)
      writeTf(bag, poseOf(settings.trajectory[next_pose]),
              trajectoryStamp(settings.trajectory[next_pose]), settings);
    bag.close();
  } catch (const rosbag::BagException& e) {
    return cli::fail(app, settings.output + ": " + e.what(), 1);
  }
  printWritten(settings, written, with_truth,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return 0;
}
