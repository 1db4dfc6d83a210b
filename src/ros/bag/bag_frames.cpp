// Pairing a scanned bag's colour, depth and camera_info by nearest stamps, the
// pose queries of the pairs, and the frame selection.

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "bag_frames.h"

#include "../conversion/message_conversion.h"
#include "bag_text.h"
#include "relocalizer/core/id_ranges.h"
#include "relocalizer/core/key_frame_rule.h"
#include "relocalizer/data/frame_selection.h"
#include "relocalizer/data/stamp_association.h"
#include "stamp_search.h"

namespace relocalizer_ros {
namespace bag_internal {

using relocalizer::FrameSelection;
using relocalizer::makeError;

std::vector<PoseQuery> poseQueries(const std::vector<SyncedFrame>& synced,
                                   const std::vector<ImageEntry>& colour,
                                   const BagOptions& options) {
  std::vector<PoseQuery> queries;
  queries.reserve(synced.size());
  for (const SyncedFrame& f : synced) {
    PoseQuery q;
    q.id = f.id;
    q.camera_frame = options.camera_frame.empty() ? stripLeadingSlashes(colour[f.colour].frame_id)
                                                  : stripLeadingSlashes(options.camera_frame);
    q.stamp = colour[f.colour].stamp;
    queries.push_back(std::move(q));
  }
  return queries;
}

relocalizer::Status synchronizeFrames(std::vector<ImageEntry>& colour,
                                      std::vector<ImageEntry>& depth,
                                      std::vector<sensor_msgs::CameraInfo>& infos,
                                      const BagOptions& options, const std::string& where,
                                      BagCounts& counts, std::vector<SyncedFrame>& synced) {
  const auto by_stamp = [](const ImageEntry& a, const ImageEntry& b) { return a.stamp < b.stamp; };
  std::stable_sort(colour.begin(), colour.end(), by_stamp);
  std::stable_sort(depth.begin(), depth.end(), by_stamp);
  std::stable_sort(infos.begin(), infos.end(),
                   [](const auto& a, const auto& b) { return a.header.stamp < b.header.stamp; });

  // Colour-depth pairs within the tolerance, nearest first, each image used
  // once, as the TUM reader pairs its lists.
  const auto seconds_of = [](const std::vector<ImageEntry>& images) {
    std::vector<double> out;
    out.reserve(images.size());
    for (const ImageEntry& e : images) out.push_back(e.stamp.toSec());
    return out;
  };
  std::vector<long> depth_of(colour.size(), -1);
  for (const auto& [c, d] :
       relocalizer::associateByStamp(seconds_of(colour), seconds_of(depth), options.sync_tolerance))
    depth_of[c] = static_cast<long>(d);

  for (size_t c = 0; c < colour.size(); ++c) {
    if (depth_of[c] < 0) {
      ++counts.colour_without_depth;
      continue;
    }
    // Nearest camera_info; several frames may share one.
    const auto [before, after] = bracket(
        infos, colour[c].stamp, [](const sensor_msgs::CameraInfo& i) { return i.header.stamp; });
    long best = -1;
    double gap = 0;
    for (long candidate : {before, after}) {
      if (candidate < 0) continue;
      const double g = std::abs((infos[candidate].header.stamp - colour[c].stamp).toSec());
      if (best < 0 || g < gap) best = candidate, gap = g;
    }
    if (best < 0 || gap > options.sync_tolerance) {
      ++counts.colour_without_info;
      continue;
    }
    // Checked here rather than frame by frame in load(): an unregistered depth
    // topic is a property of the recording, so say so before any work.
    const ImageEntry& c_entry = colour[c];
    const ImageEntry& d_entry = depth[static_cast<size_t>(depth_of[c])];
    const sensor_msgs::CameraInfo& info = infos[static_cast<size_t>(best)];
    const auto size = [](uint32_t w, uint32_t h) {
      return std::to_string(w) + "x" + std::to_string(h);
    };
    if (stripLeadingSlashes(c_entry.frame_id) != stripLeadingSlashes(d_entry.frame_id))
      return makeError(where + "depth on '" + normalTopic(options.depth_topic) + "' is in frame '" +
                       messageExcerpt(d_entry.frame_id) + "' but colour on '" +
                       normalTopic(options.rgb_topic) + "' is in frame '" +
                       messageExcerpt(c_entry.frame_id) + "' (at " + seconds(c_entry.stamp) +
                       "): depth must be registered to colour (e.g. a depth_registered topic)");
    if (c_entry.width != d_entry.width || c_entry.height != d_entry.height ||
        info.width != c_entry.width || info.height != c_entry.height)
      return makeError(where + "sizes differ at " + seconds(c_entry.stamp) + ": colour on '" +
                       normalTopic(options.rgb_topic) + "' " + size(c_entry.width, c_entry.height) +
                       ", depth on '" + normalTopic(options.depth_topic) + "' " +
                       size(d_entry.width, d_entry.height) + ", camera_info on '" +
                       normalTopic(options.camera_info_topic) + "' " +
                       size(info.width, info.height) + "; depth must be registered to colour");
    SyncedFrame f;
    f.id = static_cast<int>(synced.size());
    f.colour = c;
    f.depth = static_cast<size_t>(depth_of[c]);
    f.info = static_cast<size_t>(best);
    synced.push_back(f);
  }
  counts.synchronized = static_cast<int>(synced.size());
  if (synced.empty()) {
    const auto range = [](const auto& items, auto get) {
      return items.empty() ? std::string("none")
                           : seconds(get(items.front())) + " - " + seconds(get(items.back()));
    };
    const auto image_stamp = [](const ImageEntry& e) { return e.stamp; };
    return makeError(where + "no colour image on '" + normalTopic(options.rgb_topic) +
                     "' has a depth image on '" + normalTopic(options.depth_topic) +
                     "' and a camera_info on '" + normalTopic(options.camera_info_topic) +
                     "' within " + number(options.sync_tolerance) +
                     " s (--sync-tolerance); stamps: colour " + range(colour, image_stamp) +
                     ", depth " + range(depth, image_stamp) + ", camera_info " +
                     range(infos, [](const sensor_msgs::CameraInfo& i) { return i.header.stamp; }));
  }
  return relocalizer::okStatus();
}

relocalizer::Status selectFrames(const std::vector<SyncedFrame>& synced,
                                 const std::vector<ImageEntry>& colour, const BagOptions& options,
                                 const PoseReport& poses, const std::string& where,
                                 BagCounts& counts, std::vector<size_t>& kept) {
  auto selection = FrameSelection::parse(options.frames);
  if (!selection) return makeError(selection.error());
  relocalizer::KeyFrameSelector key_frames(options.min_translation, options.min_rotation_degrees);
  for (size_t i = 0; i < synced.size(); ++i) {
    const SyncedFrame& f = synced[i];
    if (!selection->contains(f.id)) continue;
    ++counts.selected;
    if (!f.pose) {
      ++counts.without_pose;
      continue;
    }
    ++counts.with_pose;
    if (key_frames.keep(*f.pose)) kept.push_back(i);
  }
  counts.key_frames = static_cast<int>(kept.size());
  if (counts.selected == 0)
    return makeError(where + "frame selection '" + options.frames + "' matches none of the " +
                     std::to_string(synced.size()) + " synchronized frames (ids 0-" +
                     std::to_string(synced.size() - 1) + ")");
  if (kept.empty())
    return makeError(
        where + "none of the " + std::to_string(counts.selected) +
        " selected frames (colour stamps " + seconds(colour[synced.front().colour].stamp) + " - " +
        seconds(colour[synced.back().colour].stamp) + ") has a pose from " + poses.source +
        " within " + number(options.pose_tolerance) + " s (--pose-tolerance); pose samples span " +
        (poses.begin.isZero() && poses.end.isZero()
             ? std::string("nothing (static only)")
             : seconds(poses.begin) + " - " + seconds(poses.end)) +
        (poses.no_pose_hint.empty() ? std::string() : "; " + poses.no_pose_hint));
  return relocalizer::okStatus();
}

}  // namespace bag_internal
}  // namespace relocalizer_ros
