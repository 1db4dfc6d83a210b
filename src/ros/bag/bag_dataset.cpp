#include "bag_dataset_impl.h"

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include "../conversion/message_conversion.h"
#include "bag_poses.h"
#include "bag_text.h"
#include "relocalizer/core/id_ranges.h"
#include "relocalizer/data/frame_selection.h"
#include "relocalizer/data/stamp_association.h"
#include "stamp_search.h"

namespace relocalizer_ros {

namespace {

using relocalizer::FrameSelection;
using relocalizer::makeError;

constexpr const char* kTf = "/tf";
constexpr const char* kTfStatic = "/tf_static";

template <typename T>
std::string typeName() {
  return ros::message_traits::DataType<T>::value();
}

}  // namespace

relocalizer::Status BagDataset::Impl::scan() {
  PoseInputs inputs;
  if (auto ok = checkTopics(inputs.pose_type); !ok) return ok;
  if (auto ok = readMessages(inputs); !ok) return ok;
  counts.colour_images = static_cast<int>(colour.size());
  counts.depth_images = static_cast<int>(depth.size());
  counts.camera_infos = static_cast<int>(infos.size());

  if (auto synced_ok =
          bag_internal::synchronizeFrames(colour, depth, infos, options, where(), counts, synced);
      !synced_ok)
    return synced_ok;
  std::vector<PoseQuery> queries = bag_internal::poseQueries(synced, colour, options);
  const relocalizer::Status posed =
      options.pose_topic.empty()
          ? posesFromTf(inputs.transforms, inputs.is_static, options, where(), queries, poses,
                        counts)
          : posesFromTopic(std::move(inputs.samples), inputs.pose_type, pose_child, options,
                           where(), queries, poses, counts);
  if (!posed) return posed;
  for (size_t i = 0; i < synced.size(); ++i) synced[i].pose = queries[i].pose;
  if (auto selected =
          bag_internal::selectFrames(synced, colour, options, poses, where(), counts, kept);
      !selected)
    return selected;
  for (size_t k : kept)
    for (double coefficient : infos[synced[k].info].D) distorted = distorted || coefficient != 0.0;
  camera = cameraFromInfo(infos[synced[kept.front()].info]);
  return relocalizer::okStatus();
}

relocalizer::Status BagDataset::Impl::checkTopics(std::string& pose_type) {
  const std::string rgb_topic = normalTopic(options.rgb_topic);
  const std::string depth_topic = normalTopic(options.depth_topic);
  const std::string info_topic = normalTopic(options.camera_info_topic);
  const std::string pose_topic = normalTopic(options.pose_topic);

  // Topics, types and message counts from the index (no message is read).
  rosbag::View everything(*bag);
  for (const rosbag::ConnectionInfo* c : everything.getConnections())
    topics.emplace(normalTopic(c->topic), std::make_pair(c->datatype, 0));
  for (const rosbag::MessageInstance& m : everything) ++topics[normalTopic(m.getTopic())].second;
  if (everything.size() == 0)
    return makeError(where() + "the bag is empty (no messages" +
                     (topics.empty() ? std::string(")") : ", topics " + topicList() + ")"));

  const auto require = [&](const std::string& topic, const std::string& option,
                           const std::vector<std::string>& types) -> std::string {
    const auto it = topics.find(topic);
    if (it == topics.end() || it->second.second == 0)
      return where() + "no messages on topic '" + topic + "' (" + option + "); the bag has " +
             topicList();
    if (std::find(types.begin(), types.end(), it->second.first) == types.end()) {
      std::string expected;
      for (const auto& t : types) expected += (expected.empty() ? "" : " or ") + t;
      std::string hint;
      if (it->second.first == "sensor_msgs/CompressedImage")
        hint =
            "; record the raw image topics, or decompress with `rosrun image_transport "
            "republish compressed in:=... raw out:=...` and record that";
      return where() + "topic '" + topic + "' (" + option + ") carries " + it->second.first +
             ", expected " + expected + hint;
    }
    return {};
  };
  for (const auto& [topic, option, type] :
       {std::tuple{rgb_topic, "--rgb-topic", typeName<sensor_msgs::Image>()},
        {depth_topic, "--depth-topic", typeName<sensor_msgs::Image>()},
        {info_topic, "--camera-info-topic", typeName<sensor_msgs::CameraInfo>()}})
    if (std::string why = require(topic, option, {type}); !why.empty()) return makeError(why);
  if (rgb_topic == depth_topic)
    return makeError(where() + "--rgb-topic and --depth-topic are both '" + rgb_topic + "'");

  if (options.pose_topic.empty()) {
    if (!topics.count(kTf) && !topics.count(kTfStatic))
      return makeError(where() +
                       "no poses: the bag has no /tf or /tf_static (and no --pose-topic " +
                       "was given); the bag has " + topicList());
    for (const char* t : {kTf, kTfStatic})
      if (topics.count(t))
        if (std::string why = require(t, "TF", {typeName<tf2_msgs::TFMessage>(), "tf/tfMessage"});
            !why.empty())
          return makeError(why);
  } else {
    if (std::string why =
            require(pose_topic, "--pose-topic",
                    {typeName<geometry_msgs::PoseStamped>(),
                     typeName<geometry_msgs::PoseWithCovarianceStamped>(),
                     typeName<nav_msgs::Odometry>(), typeName<geometry_msgs::TransformStamped>()});
        !why.empty())
      return makeError(why);
    pose_type = topics.at(pose_topic).first;
  }
  return relocalizer::okStatus();
}

relocalizer::Status BagDataset::Impl::readMessages(PoseInputs& inputs) {
  const std::string rgb_topic = normalTopic(options.rgb_topic);
  const std::string depth_topic = normalTopic(options.depth_topic);
  const std::string info_topic = normalTopic(options.camera_info_topic);
  const std::string pose_topic = normalTopic(options.pose_topic);
  const bool use_tf = options.pose_topic.empty();
  // One pass in bag order over every topic used; images keep only their headers.
  std::vector<std::string> wanted = {rgb_topic, depth_topic, info_topic};
  if (use_tf) {
    wanted.push_back(kTf);
    wanted.push_back(kTfStatic);
  } else {
    wanted.push_back(pose_topic);
  }
  std::set<std::string> wanted_set(wanted.begin(), wanted.end());
  rosbag::View view(*bag, [&](const rosbag::ConnectionInfo* c) {
    return wanted_set.count(normalTopic(c->topic)) > 0;
  });
  std::string pose_frame_error;
  for (const rosbag::MessageInstance& m : view) {
    const std::string topic = normalTopic(m.getTopic());
    if (topic == rgb_topic || topic == depth_topic) {
      const bool is_colour = topic == rgb_topic;
      auto image = m.instantiate<sensor_msgs::Image>();
      if (!image)
        return makeError(where() + "topic '" + topic + "': a message is not a sensor_msgs/Image");
      // Checked per message at open time, so a bad recording fails before any work.
      if (is_colour ? !colourEncodingSupported(image->encoding)
                    : !depthEncodingSupported(image->encoding))
        return makeError(
            where() + "topic '" + topic + "' (" + (is_colour ? "--rgb-topic" : "--depth-topic") +
            "): unsupported " + (is_colour ? "colour" : "depth") + " encoding '" +
            messageExcerpt(image->encoding) + "' at stamp " + seconds(image->header.stamp) +
            (is_colour ? " (expected bgr8, rgb8, bgra8, rgba8 or mono8)"
                       : " (expected 16UC1 or mono16 millimetres, or 32FC1 metres, REP 118)"));
      (is_colour ? colour_encodings : depth_encodings).insert(image->encoding);
      messages.push_back(m);
      (is_colour ? colour : depth)
          .push_back({image->header.stamp, image->header.frame_id, image->width, image->height,
                      messages.size() - 1});
    } else if (topic == info_topic) {
      auto info = m.instantiate<sensor_msgs::CameraInfo>();
      if (!info)
        return makeError(where() + "topic '" + topic +
                         "': a message is not a sensor_msgs/CameraInfo");
      infos.push_back(*info);
    } else if (topic == kTf || topic == kTfStatic) {
      auto tf = m.instantiate<tf2_msgs::TFMessage>();
      if (!tf)
        return makeError(where() + "topic '" + topic + "': a message is not a tf2_msgs/TFMessage");
      for (const auto& t : tf->transforms) {
        inputs.transforms.push_back(t);
        inputs.is_static.push_back(topic == kTfStatic);
      }
    } else if (topic == pose_topic) {
      if (auto ok = readPoseMessage(m, topic, inputs.samples, pose_frame_error); !ok) return ok;
    }
  }
  if (!pose_frame_error.empty()) return makeError(pose_frame_error);
  return relocalizer::okStatus();
}

// One message of the pose topic as a sample. A pose in another frame than the
// map frame, or of another child frame than the earlier ones, is remembered in
// `pose_frame_error` (the first such) and reported after the pass.
relocalizer::Status BagDataset::Impl::readPoseMessage(const rosbag::MessageInstance& m,
                                                      const std::string& topic,
                                                      std::vector<PoseSample>& samples,
                                                      std::string& pose_frame_error) {
  std_msgs::Header header;
  Pose pose;
  std::string child;
  if (auto p = m.instantiate<geometry_msgs::PoseStamped>()) {
    header = p->header;
    pose = fromPoseMsg(p->pose);
  } else if (auto pc = m.instantiate<geometry_msgs::PoseWithCovarianceStamped>()) {
    header = pc->header;
    pose = fromPoseMsg(pc->pose.pose);
  } else if (auto o = m.instantiate<nav_msgs::Odometry>()) {
    header = o->header;
    pose = fromPoseMsg(o->pose.pose);
    child = o->child_frame_id;
  } else if (auto ts = m.instantiate<geometry_msgs::TransformStamped>()) {
    header = ts->header;
    pose = fromTransformMsg(ts->transform);
    child = ts->child_frame_id;
  } else {
    return makeError(where() + "topic '" + topic + "': a message is not a pose (" +
                     m.getDataType() + ")");
  }
  const std::string frame = stripLeadingSlashes(header.frame_id);
  if (!frame.empty() && frame != stripLeadingSlashes(options.map_frame) && pose_frame_error.empty())
    pose_frame_error = where() + "poses on '" + topic + "' are in frame '" + frame +
                       "', not the map frame '" + stripLeadingSlashes(options.map_frame) +
                       "' (pass --map-frame " + frame + ")";
  child = stripLeadingSlashes(child);
  if (!child.empty() && pose_child.empty()) pose_child = child;
  if (!child.empty() && child != pose_child && pose_frame_error.empty())
    pose_frame_error = where() + "poses on '" + topic + "' are of frames '" + pose_child +
                       "' and '" + child + "'; a pose topic must give the camera's own pose";
  if (!pose.matrix().allFinite()) {
    ++counts.pose_samples_ignored;
    return relocalizer::okStatus();
  }
  samples.push_back({header.stamp, pose});
  ++counts.pose_samples;
  return relocalizer::okStatus();
}

BagDataset::BagDataset(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
BagDataset::~BagDataset() = default;

Expected<std::unique_ptr<BagDataset>> BagDataset::open(const std::string& path,
                                                       const BagOptions& options) {
  if (path.empty()) return makeError("bag path is empty");
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return makeError(path + ": no such file");
  if (std::filesystem::is_directory(path, ec))
    return makeError(path + ": is a folder, not a bag file");
  for (const auto& [value, name] : {std::pair{options.sync_tolerance, "--sync-tolerance"},
                                    {options.pose_tolerance, "--pose-tolerance"}})
    if (!std::isfinite(value) || value < 0)
      return makeError(std::string(name) + " must be finite and >= 0, got " + number(value));
  if (stripLeadingSlashes(options.map_frame).empty()) return makeError("the map frame is empty");

  auto impl = std::make_unique<Impl>();
  impl->path = path;
  impl->options = options;
  try {
    impl->bag = std::make_unique<rosbag::Bag>();
    try {
      impl->bag->open(path, rosbag::bagmode::Read);
    } catch (const rosbag::BagException& e) {
      // A recording that was killed has no index at its end: rosbag's reason
      // is a short read, which says nothing about the cure.
      const std::string why = e.what();
      const bool short_read = why.find("Error reading from file") != std::string::npos;
      return makeError(path + ": cannot be opened as a rosbag: " + why +
                       (short_read ? " (truncated, e.g. an interrupted recording? `rosbag reindex` "
                                     "rebuilds the index of what was written)"
                                   : ""));
    }
    if (auto ok = impl->scan(); !ok) return makeError(ok.error());
  } catch (const rosbag::BagException& e) {
    return makeError(path + ": cannot be read: " + e.what());
  } catch (const ros::Exception& e) {
    return makeError(path + ": " + e.what());
  } catch (const std::exception& e) {
    return makeError(path + ": " + e.what());
  }
  return std::unique_ptr<BagDataset>(new BagDataset(std::move(impl)));
}

size_t BagDataset::size() const { return impl_->kept.size(); }
int BagDataset::id(size_t i) const { return impl_->synced[impl_->kept.at(i)].id; }
double BagDataset::stamp(size_t i) const {
  return impl_->colour[impl_->synced[impl_->kept.at(i)].colour].stamp.toSec();
}
const std::optional<Pose>& BagDataset::groundTruth(size_t i) const {
  return impl_->synced[impl_->kept.at(i)].pose;
}
const CameraIntrinsics& BagDataset::camera() const { return impl_->camera; }
const std::string& BagDataset::path() const { return impl_->path; }
const std::string& BagDataset::poseSource() const { return impl_->poses.source; }
const BagCounts& BagDataset::counts() const { return impl_->counts; }

Expected<RgbdFrame> BagDataset::load(size_t i) const {
  if (i >= size())
    return makeError("frame index " + std::to_string(i) + " is out of range: " + impl_->path +
                     " has " + std::to_string(size()) + " kept frames");
  const Impl::Frame& f = impl_->synced[impl_->kept[i]];
  const Impl::ImageEntry& c = impl_->colour[f.colour];
  const Impl::ImageEntry& d = impl_->depth[f.depth];
  const std::string where = impl_->path + ": frame " + std::to_string(f.id) + " (" +
                            normalTopic(impl_->options.rgb_topic) + " at " + seconds(c.stamp) +
                            ", " + normalTopic(impl_->options.depth_topic) + " at " +
                            seconds(d.stamp) + ")";
  sensor_msgs::ImageConstPtr colour, depth;
  try {
    std::lock_guard<std::mutex> lock(impl_->bag_mutex);
    colour = impl_->messages[c.message].instantiate<sensor_msgs::Image>();
    depth = impl_->messages[d.message].instantiate<sensor_msgs::Image>();
  } catch (const std::exception& e) {
    return makeError(where + ": cannot be read: " + e.what());
  }
  if (!colour || !depth) return makeError(where + ": cannot be read as sensor_msgs/Image");
  auto frame = frameFromMessages(*colour, *depth, impl_->infos[f.info]);
  if (!frame) return makeError(where + ": " + frame.error());
  frame->id = f.id;
  frame->stamp = c.stamp.toSec();
  frame->ground_truth = f.pose;
  frame->source = where;
  return std::move(*frame);
}

std::string BagDataset::summary() const {
  const Impl& d = *impl_;
  const BagCounts& n = d.counts;
  std::ostringstream out;
  const auto encodings = [](const std::set<std::string>& set) {
    std::string text;
    for (const auto& e : set) text += (text.empty() ? "" : "/") + e;
    return text;
  };
  out << "format:       rosbag\n";
  out << "bag:          " << d.path << "\n";
  out << "topics:       colour " << normalTopic(d.options.rgb_topic) << " (" << n.colour_images
      << ", " << encodings(d.colour_encodings) << "), depth " << normalTopic(d.options.depth_topic)
      << " (" << n.depth_images << ", " << encodings(d.depth_encodings) << "), camera_info "
      << normalTopic(d.options.camera_info_topic) << " (" << n.camera_infos << ")\n";
  out << "synchronized: " << n.synchronized << " frames (colour + depth + camera_info within "
      << number(d.options.sync_tolerance) << " s)";
  if (n.colour_without_depth || n.colour_without_info)
    out << "; " << n.colour_without_depth << " colour images without depth, "
        << n.colour_without_info << " without camera_info";
  out << ", stamps " << seconds(d.colour[d.synced.front().colour].stamp) << " - "
      << seconds(d.colour[d.synced.back().colour].stamp) << "\n";
  if (n.selected != n.synchronized)
    out << "selected:     " << n.selected << " by '" << d.options.frames << "'\n";
  out << "poses:        " << d.poses.source << ", " << d.poses.detail << "; tolerance "
      << number(d.options.pose_tolerance) << " s: " << n.with_pose << " with a pose, "
      << n.without_pose << " skipped without a pose in time\n";
  if (n.without_pose > 0 && !d.poses.no_pose_hint.empty())
    out << "              " << d.poses.no_pose_hint << "\n";
  std::vector<int> ids;
  for (size_t i = 0; i < size(); ++i) ids.push_back(id(i));
  out << "key frames:   ";
  if (d.options.min_translation > 0 || d.options.min_rotation_degrees > 0)
    out << n.key_frames << " of " << n.with_pose
        << " moved >= " << number(d.options.min_translation)
        << " m or turned >= " << number(d.options.min_rotation_degrees)
        << " deg since the last kept\n";
  else
    out << "off (every frame with a pose)\n";
  // Key frames of a long recording are thousands of single ids: show both ends.
  std::string id_list = relocalizer::formatIdRanges(ids);
  if (id_list.size() > 100) {
    const size_t head = id_list.rfind(',', 60), tail = id_list.find(',', id_list.size() - 30);
    if (head != std::string::npos && tail != std::string::npos && head < tail)
      id_list = id_list.substr(0, head) + ",...," + id_list.substr(tail + 1);
  }
  out << "frames:       " << size() << " kept, ids " << id_list << "\n";
  out << "image size:   " << d.camera.width << "x" << d.camera.height << "\n";
  out << "intrinsics:   fx " << number(d.camera.fx) << " fy " << number(d.camera.fy) << " cx "
      << number(d.camera.cx) << " cy " << number(d.camera.cy) << " (camera_info "
      << intrinsicsMatrixName(d.infos[d.synced[d.kept.front()].info])
      << (d.distorted ? "; its distortion D is not zero and is ignored, as the node does: "
                        "rectified images train better"
                      : "")
      << ")\n";
  // Path length over consecutive synchronized frames with poses, like the
  // dataset summary's consecutive ids, so skipped frames do not count.
  double length = 0.0;
  for (size_t i = 1; i < d.synced.size(); ++i)
    if (d.synced[i - 1].pose && d.synced[i].pose)
      length += (d.synced[i].pose->translation() - d.synced[i - 1].pose->translation()).norm();
  out << "path length:  " << number(length, "%.2f") << " m (poses of consecutive frames)\n";
  return out.str();
}

}  // namespace relocalizer_ros
