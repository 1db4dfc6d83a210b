#include "node_places.h"

#include <algorithm>
#include <boost/bind/bind.hpp>
#include <filesystem>

#include "message_conversion.h"

namespace relocalizer_ros {

namespace {

relocalizer::Expected<relocalizer::Place> loadPlace(const PlaceSpec& spec,
                                                    const relocalizer::RelocalizerParams& params) {
  return relocalizer::PlaceSet::load(spec.name, spec.model, spec.map_frame, params);
}

template <typename Service, typename Handler>
ros::ServiceServer advertiseOn(ros::NodeHandle& nh, const std::string& name, Handler handler,
                               ServiceCallQueue& calls) {
  auto options =
      ros::AdvertiseServiceOptions::create<Service>(name, handler, ros::VoidConstPtr(), &calls);
  return nh.advertiseService(options);
}

void warnLimitations(const relocalizer::Place& place) {
  if (const std::string limits = place.relocalizer->limitations(); !limits.empty())
    ROS_WARN("relocalizer: place '%s' (%s): %s", place.name.c_str(), place.source.c_str(),
             limits.c_str());
}

}  // namespace

std::string placeText(const relocalizer::PlaceFigures& f) {
  return "'" + f.name + "' in " + f.map_frame + " (" +
         (f.source.empty() ? std::string("learned") : f.source) + ", " +
         std::to_string(f.point_trees) + " point trees, " + std::to_string(f.line_trees) +
         " line trees)";
}

relocalizer::Expected<std::unique_ptr<NodePlaces>> NodePlaces::create(const NodeParams& params,
                                                                      LearnedModel learned) {
  std::unique_ptr<NodePlaces> places(new NodePlaces(params, std::move(learned)));
  std::vector<std::string> failures;
  for (const PlaceSpec& spec : startupPlaces(params)) {
    auto place = loadPlace(spec, params.relocalizer);
    if (!place) {
      failures.push_back(place.error());
    } else if (const relocalizer::Status put = places->places_.put(*place); !put) {
      failures.push_back(put.error());
    } else {
      warnLimitations(*place);
    }
  }
  if (places->places_.size() == 0 && !places->learning()) {
    std::string why;
    for (const std::string& failure : failures) why += (why.empty() ? "" : "; ") + failure;
    return relocalizer::makeError(why);
  }
  // The node runs on the places that did load; each one that did not says why.
  for (const std::string& failure : failures) ROS_ERROR("relocalizer: %s", failure.c_str());
  return places;
}

NodePlaces::NodePlaces(const NodeParams& params, LearnedModel learned)
    : params_(params), learned_(std::move(learned)), learned_name_(placeName(params)) {}

void NodePlaces::advertise(ros::NodeHandle private_nh, ServiceCallQueue& calls) {
  using boost::placeholders::_1;
  using boost::placeholders::_2;
  load_service_ = advertiseOn<relocalizer::LoadPlace>(
      private_nh, "load_place", boost::bind(&NodePlaces::onLoad, this, _1, _2), calls);
  unload_service_ = advertiseOn<relocalizer::UnloadPlace>(
      private_nh, "unload_place", boost::bind(&NodePlaces::onUnload, this, _1, _2), calls);
  list_service_ = advertiseOn<relocalizer::ListPlaces>(
      private_nh, "list_places", boost::bind(&NodePlaces::onList, this, _1, _2), calls);
}

void NodePlaces::shutdown() {
  load_service_.shutdown();
  unload_service_.shutdown();
  list_service_.shutdown();
}

void NodePlaces::followLearner() {
  if (!learned_) return;
  std::shared_ptr<const relocalizer::Relocalizer> current = learned_();
  {
    std::lock_guard<std::mutex> lock(learned_mutex_);
    if (current == learned_model_) return;
    learned_model_ = current;
    if (!current) return;
    relocalizer::Place place;
    place.name = learned_name_;
    place.map_frame = params_.map_frame;
    place.relocalizer = std::move(current);
    if (const relocalizer::Status put = places_.put(std::move(place)); !put) {
      if (log_.allow(put.error()))
        ROS_WARN("relocalizer: the learned model: %s", put.error().c_str());
      return;
    }
  }
  if (changed_) changed_();
}

relocalizer::PlaceAnswer NodePlaces::relocalize(const relocalizer::RgbdFrame& frame,
                                                const relocalizer::PoseHint* hint) {
  followLearner();
  return places_.relocalize(frame, hint);
}

std::vector<relocalizer::PlaceFigures> NodePlaces::list() {
  followLearner();
  return places_.list();
}

bool NodePlaces::empty() {
  followLearner();
  return places_.size() == 0;
}

bool NodePlaces::onLoad(relocalizer::LoadPlace::Request& request,
                        relocalizer::LoadPlace::Response& response) {
  response.success = false;
  PlaceSpec spec;
  spec.name = request.name;
  spec.map_frame = stripLeadingSlashes(request.map_frame);
  if (spec.map_frame.empty()) spec.map_frame = params_.map_frame;
  // Relative to the node's working folder (ROS_HOME), which the caller does
  // not know: the answer names the file absolutely.
  std::error_code ignored;
  if (!request.model.empty())
    spec.model = std::filesystem::absolute(request.model, ignored).lexically_normal().string();
  if (spec.name.empty()) {
    response.message = "name is empty: name the place";
  } else if (spec.model.empty()) {
    response.message = "model is empty: name the model file of place '" + spec.name + "'";
  } else if (learning() && spec.name == learned_name_) {
    response.message = "'" + spec.name + "' is the learned place; choose another name";
  } else if (!params_.odom_frame.empty() && spec.map_frame == params_.odom_frame) {
    response.message = "map_frame " + spec.map_frame + " is the odom_frame";
  } else {
    const std::vector<std::string> before = places_.names();
    const bool replaces = std::find(before.begin(), before.end(), spec.name) != before.end();
    auto place = loadPlace(spec, params_.relocalizer);
    const relocalizer::Status put =
        place ? places_.put(*place) : relocalizer::Status(relocalizer::makeError(place.error()));
    response.success = put.ok();
    if (put) {
      if (changed_) changed_();
      warnLimitations(*place);
      response.message = std::string(replaces ? "replaced" : "loaded") + " place " +
                         placeText(relocalizer::placeFigures(*place));
    } else {
      response.message = put.error();
    }
  }
  if (response.success)
    ROS_INFO("relocalizer: ~load_place: %s", response.message.c_str());
  else
    ROS_WARN("relocalizer: ~load_place refused: %s", response.message.c_str());
  return true;
}

bool NodePlaces::onUnload(relocalizer::UnloadPlace::Request& request,
                          relocalizer::UnloadPlace::Response& response) {
  if (learning() && request.name == learned_name_) {
    response.success = false;
    response.message = "'" + request.name + "' is the learned place; it follows the learner";
  } else {
    response.success = places_.remove(request.name);
    if (response.success && changed_) changed_();
    response.message = response.success ? "unloaded place '" + request.name + "'"
                                        : "no place named " + request.name;
  }
  ROS_INFO("relocalizer: ~unload_place: %s", response.message.c_str());
  return true;
}

bool NodePlaces::onList(relocalizer::ListPlaces::Request&,
                        relocalizer::ListPlaces::Response& response) {
  for (const relocalizer::PlaceFigures& f : list()) {
    relocalizer::PlaceInfo info;
    info.name = f.name;
    info.map_frame = f.map_frame;
    info.model = f.source;
    info.point_trees = static_cast<uint32_t>(f.point_trees);
    info.line_trees = static_cast<uint32_t>(f.line_trees);
    info.modes = static_cast<uint64_t>(f.modes);
    info.surface_voxels = static_cast<uint64_t>(f.surface_voxels);
    info.training_frames = static_cast<uint64_t>(f.training_frames);
    info.model_bytes = f.model_bytes;
    response.places.push_back(std::move(info));
  }
  return true;
}

}  // namespace relocalizer_ros
