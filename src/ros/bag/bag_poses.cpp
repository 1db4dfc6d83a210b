#include "bag_poses.h"

#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "../conversion/message_conversion.h"
#include "bag_text.h"
#include "relocalizer/core/statistics.h"
#include "stamp_search.h"

namespace relocalizer_ros {

namespace {

using relocalizer::makeError;

// One TF edge: child -> parent, with the stamps of its samples (dynamic edges).
struct TfEdge {
  std::string parent;
  bool is_static = true;
  std::vector<ros::Time> stamps;  // sorted, unique
};

// ", one every 0.1 s (median)" for a hint at the tolerance a stream needs.
std::string medianSpacing(const std::vector<ros::Time>& stamps) {
  if (stamps.size() < 2) return {};
  std::vector<double> gaps;
  for (size_t i = 1; i < stamps.size(); ++i) gaps.push_back((stamps[i] - stamps[i - 1]).toSec());
  return ", one every " + number(relocalizer::median(gaps), "%.3g") + " s (median)";
}

// The TF tree of a bag: its edges by child frame, the transforms tf2 may take,
// and the time span of the dynamic ones (zero: none).
struct TfTree {
  std::map<std::string, TfEdge> edges;
  std::vector<size_t> usable;
  ros::Time first, last;
};

// Edges and their sample stamps, cleaned of what tf2 would reject with a log
// line per message: empty or self frames, non-finite values, repeated stamps.
TfTree readTfTree(const std::vector<geometry_msgs::TransformStamped>& transforms,
                  const std::vector<bool>& is_static, BagCounts& counts) {
  TfTree tree;
  std::set<std::pair<std::string, ros::Time>> seen;
  for (size_t i = 0; i < transforms.size(); ++i) {
    ++counts.tf_transforms;
    const auto& t = transforms[i];
    const std::string parent = stripLeadingSlashes(t.header.frame_id);
    const std::string child = stripLeadingSlashes(t.child_frame_id);
    const auto& q = t.transform.rotation;
    const auto& v = t.transform.translation;
    const bool finite = std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z) &&
                        std::isfinite(q.w) && std::isfinite(v.x) && std::isfinite(v.y) &&
                        std::isfinite(v.z) &&
                        (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w) > 1e-12;
    if (parent.empty() || child.empty() || parent == child || !finite ||
        (!is_static[i] && !seen.insert({child, t.header.stamp}).second)) {
      ++counts.tf_ignored;
      continue;
    }
    TfEdge& edge = tree.edges[child];
    edge.parent = parent;
    if (!is_static[i]) {
      edge.is_static = false;
      edge.stamps.push_back(t.header.stamp);
      if (tree.first.isZero() || t.header.stamp < tree.first) tree.first = t.header.stamp;
      if (tree.last.isZero() || t.header.stamp > tree.last) tree.last = t.header.stamp;
    }
    tree.usable.push_back(i);
  }
  for (auto& [child, edge] : tree.edges) std::sort(edge.stamps.begin(), edge.stamps.end());
  return tree;
}

// The frames present, for messages that must say what the bag does have.
std::set<std::string> tfFrames(const TfTree& tree) {
  std::set<std::string> frames;
  for (const auto& [child, edge] : tree.edges) {
    frames.insert(child);
    frames.insert(edge.parent);
  }
  return frames;
}

// "a (root), b (child of a, static), ..." or "none".
std::string frameList(const TfTree& tree) {
  std::string text;
  for (const std::string& f : tfFrames(tree)) {
    const auto it = tree.edges.find(f);
    text += (text.empty() ? "" : ", ") + f +
            (it == tree.edges.end()
                 ? " (root)"
                 : " (child of " + it->second.parent + (it->second.is_static ? ", static)" : ")"));
  }
  return text.empty() ? std::string("none") : text;
}

// Path to the root, the frame itself first (cycles cut).
std::vector<std::string> ancestors(const TfTree& tree, const std::string& frame) {
  std::vector<std::string> chain{frame};
  std::set<std::string> visited{frame};
  for (auto it = tree.edges.find(frame); it != tree.edges.end();
       it = tree.edges.find(chain.back())) {
    if (!visited.insert(it->second.parent).second) break;
    chain.push_back(it->second.parent);
  }
  return chain;
}

using DynamicPaths = std::map<std::string, std::vector<const TfEdge*>>;

// Per camera frame: the dynamic edges between it and the map frame; an error
// naming the frames the bag has when no path joins them.
relocalizer::Expected<DynamicPaths> dynamicPaths(const TfTree& tree,
                                                 const std::vector<PoseQuery>& queries,
                                                 const BagOptions& options,
                                                 const std::string& map_frame,
                                                 const std::string& where) {
  DynamicPaths paths;
  for (const PoseQuery& q : queries) {
    const std::string camera_frame = q.camera_frame;
    if (paths.count(camera_frame)) continue;
    if (camera_frame.empty())
      return makeError(where + "colour images on '" + normalTopic(options.rgb_topic) +
                       "' have an empty header frame_id; pass --camera-frame");
    const auto up_camera = ancestors(tree, camera_frame);
    const auto up_map = ancestors(tree, map_frame);
    auto common = up_camera.end();
    for (auto it = up_camera.begin(); it != up_camera.end() && common == up_camera.end(); ++it)
      if (std::find(up_map.begin(), up_map.end(), *it) != up_map.end()) common = it;
    if (common == up_camera.end()) {
      const std::set<std::string> frames = tfFrames(tree);
      std::string missing;
      for (const std::string& name : {map_frame, camera_frame})
        if (!frames.count(name)) missing += "; '" + name + "' is not in /tf or /tf_static";
      return makeError(where + "no TF path from the map frame '" + map_frame +
                       "' (--map-frame) to the camera frame '" + camera_frame + "' (" +
                       (options.camera_frame.empty() ? "the colour images' frame_id; --camera-frame"
                                                     : "--camera-frame") +
                       ")" + missing + "; TF frames in the bag: " + frameList(tree));
    }
    std::vector<const TfEdge*> dynamic;
    const auto collect = [&](const std::vector<std::string>& chain, const std::string& stop) {
      for (const std::string& frame : chain) {
        if (frame == stop) break;
        const TfEdge& edge = tree.edges.at(frame);
        if (!edge.is_static) dynamic.push_back(&edge);
      }
    };
    collect(up_camera, *common);
    collect(up_map, *common);
    paths[camera_frame] = dynamic;
  }
  return paths;
}

// Why frame q has no pose: `edge` has no samples around its stamp.
std::string noSamplesHint(const TfTree& tree, const TfEdge& edge, const PoseQuery& q,
                          const BagOptions& options) {
  std::string child;
  for (const auto& [name, e] : tree.edges)
    if (&e == &edge) child = name;
  return "e.g. frame " + std::to_string(q.id) + " at " + seconds(q.stamp) + ": TF " + edge.parent +
         " -> " + child + " has no samples within " + number(options.pose_tolerance) +
         " s on both sides (its samples span " +
         (edge.stamps.empty()
              ? std::string("nothing")
              : seconds(edge.stamps.front()) + " - " + seconds(edge.stamps.back())) +
         medianSpacing(edge.stamps) + ")";
}

// Each query's pose from tf2, when every dynamic edge on its path has samples
// within the tolerance on both sides of its stamp.
void lookUpPoses(const TfTree& tree, const tf2::BufferCore& buffer, const DynamicPaths& paths,
                 const BagOptions& options, const std::string& map_frame,
                 std::vector<PoseQuery>& queries, PoseReport& report) {
  for (PoseQuery& q : queries) {
    const std::string camera_frame = q.camera_frame;
    const ros::Time t = q.stamp;
    bool in_time = true;
    for (const TfEdge* edge : paths.at(camera_frame))
      if (!inTime(edge->stamps, t, options.pose_tolerance, [](const ros::Time& s) { return s; })) {
        in_time = false;
        if (report.no_pose_hint.empty())
          report.no_pose_hint = noSamplesHint(tree, *edge, q, options);
        break;
      }
    if (!in_time) continue;
    try {
      q.pose = fromTransformMsg(buffer.lookupTransform(map_frame, camera_frame, t).transform);
    } catch (const tf2::TransformException& e) {
      if (report.no_pose_hint.empty())
        report.no_pose_hint =
            "e.g. frame " + std::to_string(q.id) + " at " + seconds(t) + ": " + e.what();
    }
  }
}

}  // namespace

relocalizer::Status posesFromTf(const std::vector<geometry_msgs::TransformStamped>& transforms,
                                const std::vector<bool>& is_static, const BagOptions& options,
                                const std::string& where, std::vector<PoseQuery>& queries,
                                PoseReport& report, BagCounts& counts) {
  const TfTree tree = readTfTree(transforms, is_static, counts);

  // The cache must hold the whole recording, or lookups early in the bag
  // would fail once later transforms are inserted.
  const double span = tree.last.isZero() ? 0.0 : (tree.last - tree.first).toSec();
  tf2::BufferCore buffer(ros::Duration(span + 10.0));
  for (size_t i : tree.usable) {
    geometry_msgs::TransformStamped t = transforms[i];
    t.header.frame_id = stripLeadingSlashes(t.header.frame_id);
    t.child_frame_id = stripLeadingSlashes(t.child_frame_id);
    buffer.setTransform(t, "bag", is_static[i]);
  }
  report.begin = tree.first;
  report.end = tree.last;

  const std::string map_frame = stripLeadingSlashes(options.map_frame);
  const auto paths = dynamicPaths(tree, queries, options, map_frame, where);
  if (!paths) return makeError(paths.error());
  lookUpPoses(tree, buffer, *paths, options, map_frame, queries, report);

  report.source =
      "TF " + map_frame + " -> " +
      (options.camera_frame.empty() ? "image frame_id" : stripLeadingSlashes(options.camera_frame));
  if (options.camera_frame.empty() && paths->size() == 1)
    report.source = "TF " + map_frame + " -> " + paths->begin()->first;
  report.detail = std::to_string(counts.tf_transforms) + " transforms on /tf + /tf_static" +
                  (counts.tf_ignored ? " (" + std::to_string(counts.tf_ignored) +
                                           " ignored: repeated stamps, NaN, empty or self frames)"
                                     : std::string());
  return relocalizer::okStatus();
}

relocalizer::Status posesFromTopic(std::vector<PoseSample> samples, const std::string& type,
                                   const std::string& pose_child, const BagOptions& options,
                                   const std::string& where, std::vector<PoseQuery>& queries,
                                   PoseReport& report, const BagCounts& counts) {
  // Odometry and TransformStamped name the frame they locate: it must be the camera's.
  if (!pose_child.empty())
    for (const PoseQuery& q : queries)
      if (q.camera_frame != pose_child)
        return makeError(
            where + "poses on '" + normalTopic(options.pose_topic) + "' are of frame '" +
            pose_child + "', not the camera frame '" + q.camera_frame + "' (" +
            (options.camera_frame.empty() ? "the colour images' frame_id" : "--camera-frame") +
            "); a pose topic must give the camera's own pose (or use TF)");
  std::stable_sort(samples.begin(), samples.end(),
                   [](const PoseSample& a, const PoseSample& b) { return a.stamp < b.stamp; });
  if (!samples.empty()) {
    report.begin = samples.front().stamp;
    report.end = samples.back().stamp;
  }
  const auto stamp_of = [](const PoseSample& s) { return s.stamp; };
  for (PoseQuery& q : queries) {
    const ros::Time t = q.stamp;
    long before = -1, after = -1;
    if (!inTime(samples, t, options.pose_tolerance, stamp_of, &before, &after)) {
      if (report.no_pose_hint.empty())
        report.no_pose_hint = "e.g. frame " + std::to_string(q.id) + " at " + seconds(t) +
                              " has no pose sample within " + number(options.pose_tolerance) +
                              " s on both sides";
      continue;
    }
    const PoseSample& a = samples[before];
    const PoseSample& b = samples[after];
    if (a.stamp == t || b.stamp == a.stamp) {
      q.pose = a.stamp == t ? a.pose : b.pose;
      continue;
    }
    const double r = (t - a.stamp).toSec() / (b.stamp - a.stamp).toSec();
    Pose pose = Pose::Identity();
    pose.translation() = (1.0 - r) * a.pose.translation() + r * b.pose.translation();
    pose.linear() = Eigen::Quaterniond(a.pose.linear())
                        .slerp(r, Eigen::Quaterniond(b.pose.linear()))
                        .normalized()
                        .toRotationMatrix();
    q.pose = pose;
  }
  report.source = "topic " + normalTopic(options.pose_topic) + " (" + type + ")";
  report.detail = std::to_string(samples.size()) + " samples" +
                  (counts.pose_samples_ignored
                       ? " (" + std::to_string(counts.pose_samples_ignored) + " non-finite ignored)"
                       : std::string());
  return relocalizer::okStatus();
}

}  // namespace relocalizer_ros
