#pragma once
// What RViz shows of the node (rviz/relocalizer.rviz): the places' surfaces on
// the latched ~surface and each answer's inlier samples on ~inliers.
//
// ~surface is one cloud, in the node's map_frame: the surfaces of every place
// in that frame, merged. One cloud and not one message per place because a
// latched topic keeps only its last message, so a late subscriber (RViz
// started after the node) would see one place of many. A place loaded into
// another frame is not drawn on it. It is published at start and again after
// a change of the places drawn (~load_place, ~unload_place, a retrained learned
// model in map_frame), always from the places as they are when it is built, so
// the last cloud is never older than the last change; a change elsewhere
// (another frame) sends nothing. At most one cloud per kSurfaceInterval: the
// changes of a storm of loads are one cloud (issue 38, R2: every load and
// unload sent every place's surface, 722 MB in 30 s). Each point is coloured by its
// normal (|x|, |y|, |z| as red, green, blue), so walls, floor and furniture
// tell apart in a flat-shaded view.
//
// ~inliers (latched too: RViz started late shows the last answer), for every
// answer with a pose, in the answering place's frame at the
// frame's stamp: the inlier samples where the answer puts them (Relocalization's
// point_inlier_world and line_inlier_world), point_inliers + line_inliers
// points. Field `kind` is 0 for a point sample and 1 for a line sample, and
// `rgb` draws them orange and cyan.

#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "node_output.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer_ros {

using PlaceList = std::vector<std::shared_ptr<const relocalizer::Place>>;

enum class InlierKind : uint8_t { Point = 0, Line = 1 };

// The clouds, apart from the publishers so that tests can read them.
sensor_msgs::PointCloud2 surfaceCloud(const PlaceList& places, const std::string& map_frame);
sensor_msgs::PointCloud2 inlierCloud(const relocalizer::Relocalization& answer,
                                     const std_msgs::Header& header);

// The shortest time between two ~surface clouds, s.
constexpr double kSurfaceInterval = 1.0;

class NodeVisuals {
 public:
  // `places` gives the places as they are now.
  NodeVisuals(ros::NodeHandle private_nh, std::string map_frame, std::function<PlaceList()> places);
  ~NodeVisuals();
  NodeVisuals(const NodeVisuals&) = delete;
  NodeVisuals& operator=(const NodeVisuals&) = delete;

  // ~surface again, from the places as they are then, if those drawn changed:
  // returns at once; the cloud is built and sent on a thread of its own.
  void placesChanged();
  // The NodeOutput listener: ~inliers of each answer with a pose.
  void onPublished(const NodeOutput::Published& published);

 private:
  void surfaceLoop();
  // Whether `drawn` (places in map_frame now) are the places of the last cloud.
  bool sameAsLastCloud(const PlaceList& drawn) const;

  const std::string map_frame_;
  const std::function<PlaceList()> places_;
  ros::Publisher surface_pub_;
  ros::Publisher inliers_pub_;

  std::mutex surface_mutex_;
  std::condition_variable surface_wake_;
  bool changed_ = false;
  bool stopping_ = false;
  bool sent_any_ = false;
  // The last cloud's places, weakly: an unloaded place's memory goes.
  std::vector<std::weak_ptr<const relocalizer::Place>> last_drawn_;
  std::thread surface_thread_;
};

}  // namespace relocalizer_ros
