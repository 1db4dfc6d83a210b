#include "node_visuals.h"

#include <sensor_msgs/point_cloud2_iterator.h>

#include <cmath>
#include <cstring>

namespace relocalizer_ros {

namespace {

// RViz's packed colour: 0x00RRGGBB in the bytes of a float32.
float packedRgb(uint8_t r, uint8_t g, uint8_t b) {
  const uint32_t packed = (uint32_t(r) << 16) | (uint32_t(g) << 8) | uint32_t(b);
  float value;
  std::memcpy(&value, &packed, sizeof value);
  return value;
}

// 64..255: a normal's weak axes stay visible against a black background.
uint8_t channelOf(float component) {
  return static_cast<uint8_t>(64.0f + 191.0f * std::min(1.0f, std::fabs(component)));
}

constexpr uint8_t kPointColour[3] = {255, 140, 0};  // orange
constexpr uint8_t kLineColour[3] = {0, 220, 255};   // cyan

}  // namespace

sensor_msgs::PointCloud2 surfaceCloud(const PlaceList& places, const std::string& map_frame) {
  size_t count = 0;
  for (const auto& place : places)
    if (place->map_frame == map_frame)
      count += place->relocalizer->model().surface.elements().size();
  sensor_msgs::PointCloud2 cloud;
  cloud.header.frame_id = map_frame;
  cloud.header.stamp = ros::Time::now();
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2FieldsByString(2, "xyz", "rgb");
  modifier.resize(count);
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z"),
      rgb(cloud, "rgb");
  for (const auto& place : places) {
    if (place->map_frame != map_frame) continue;
    for (const relocalizer::SurfaceElement& e : place->relocalizer->model().surface.elements()) {
      *x = e.point.x();
      *y = e.point.y();
      *z = e.point.z();
      *rgb = packedRgb(channelOf(e.normal.x()), channelOf(e.normal.y()), channelOf(e.normal.z()));
      ++x, ++y, ++z, ++rgb;
    }
  }
  return cloud;
}

sensor_msgs::PointCloud2 inlierCloud(const relocalizer::Relocalization& answer,
                                     const std_msgs::Header& header) {
  sensor_msgs::PointCloud2 cloud;
  cloud.header = header;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(
      5, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
      sensor_msgs::PointField::FLOAT32, "rgb", 1, sensor_msgs::PointField::FLOAT32, "kind", 1,
      sensor_msgs::PointField::UINT8);
  modifier.resize(answer.point_inlier_world.size() + answer.line_inlier_world.size());
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z"),
      rgb(cloud, "rgb");
  sensor_msgs::PointCloud2Iterator<uint8_t> kind(cloud, "kind");
  for (const InlierKind k : {InlierKind::Point, InlierKind::Line}) {
    const bool line = k == InlierKind::Line;
    const uint8_t* colour = line ? kLineColour : kPointColour;
    for (const Eigen::Vector3f& p : line ? answer.line_inlier_world : answer.point_inlier_world) {
      *x = p.x();
      *y = p.y();
      *z = p.z();
      *rgb = packedRgb(colour[0], colour[1], colour[2]);
      *kind = static_cast<uint8_t>(k);
      ++x, ++y, ++z, ++rgb, ++kind;
    }
  }
  return cloud;
}

NodeVisuals::NodeVisuals(ros::NodeHandle private_nh, std::string map_frame,
                         std::function<PlaceList()> places)
    : map_frame_(std::move(map_frame)), places_(std::move(places)) {
  surface_pub_ = private_nh.advertise<sensor_msgs::PointCloud2>("surface", 1, true);
  inliers_pub_ = private_nh.advertise<sensor_msgs::PointCloud2>("inliers", 1, true);
  surface_thread_ = std::thread(&NodeVisuals::surfaceLoop, this);
}

NodeVisuals::~NodeVisuals() {
  {
    std::lock_guard<std::mutex> lock(surface_mutex_);
    stopping_ = true;
  }
  surface_wake_.notify_all();
  surface_thread_.join();
}

void NodeVisuals::placesChanged() {
  {
    std::lock_guard<std::mutex> lock(surface_mutex_);
    changed_ = true;
  }
  surface_wake_.notify_all();
}

bool NodeVisuals::sameAsLastCloud(const PlaceList& drawn) const {
  if (!sent_any_ || drawn.size() != last_drawn_.size()) return false;
  for (size_t i = 0; i < drawn.size(); ++i)
    if (last_drawn_[i].lock() != drawn[i]) return false;
  return true;
}

void NodeVisuals::surfaceLoop() {
  std::unique_lock<std::mutex> lock(surface_mutex_);
  while (true) {
    surface_wake_.wait(lock, [this] { return stopping_ || changed_; });
    if (stopping_) return;
    changed_ = false;
    PlaceList drawn;
    for (auto& place : places_())
      if (place->map_frame == map_frame_) drawn.push_back(std::move(place));
    if (sameAsLastCloud(drawn)) continue;
    lock.unlock();
    surface_pub_.publish(surfaceCloud(drawn, map_frame_));
    lock.lock();
    sent_any_ = true;
    last_drawn_.assign(drawn.begin(), drawn.end());
    drawn.clear();
    // Changes that come meanwhile wait for the interval's end, then are one cloud.
    surface_wake_.wait_for(lock, std::chrono::duration<double>(kSurfaceInterval),
                           [this] { return stopping_; });
  }
}

void NodeVisuals::onPublished(const NodeOutput::Published& published) {
  if (!published.found || !published.result.success) return;
  inliers_pub_.publish(inlierCloud(published.found->relocalization, published.result.header));
}

}  // namespace relocalizer_ros
