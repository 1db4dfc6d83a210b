#include "node_places.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <boost/bind/bind.hpp>
#include <chrono>
#include <filesystem>
#include <thread>

#include "../conversion/message_conversion.h"
#include "relocalizer/core/outside_text.h"
#include "relocalizer/online/learned_places.h"
#include "relocalizer/online/place_files.h"

namespace relocalizer_ros {

namespace {

// A model file is one place; a folder of learned submaps (saved by learn
// mode) is a group of places `name/i`, all in the spec's map frame
// (online/place_files.h); the folder's skipped submaps are logged.
relocalizer::Expected<relocalizer::PlaceFiles> loadPlaces(
    const PlaceSpec& spec, const relocalizer::RelocalizerParams& params) {
  auto loaded = relocalizer::openPlace(spec.name, spec.model, spec.map_frame, params);
  if (!loaded || !loaded->folder) return loaded;
  for (const std::string& warning : loaded->warnings)
    ROS_WARN("relocalizer: place '%s': %s", spec.name.c_str(), warning.c_str());
  if (loaded->saved_map_frame != spec.map_frame)
    ROS_WARN("relocalizer: place '%s': %s was learned in %s and is answered in %s",
             spec.name.c_str(), spec.model.c_str(), loaded->saved_map_frame.c_str(),
             spec.map_frame.c_str());
  return loaded;
}

template <typename Service, typename Handler>
ros::ServiceServer advertiseOn(ros::NodeHandle& nh, const std::string& name, Handler handler,
                               ServiceCallQueue& calls) {
  auto options =
      ros::AdvertiseServiceOptions::create<Service>(name, handler, ros::VoidConstPtr(), &calls);
  return nh.advertiseService(options);
}

// The places of `before` that `places` no longer holds, weakly.
std::vector<std::weak_ptr<const relocalizer::Place>> goneFrom(
    const std::vector<std::shared_ptr<const relocalizer::Place>>& before,
    const relocalizer::PlaceSet& places) {
  const auto now = places.places();
  std::vector<std::weak_ptr<const relocalizer::Place>> gone;
  for (const auto& place : before)
    if (std::find(now.begin(), now.end(), place) == now.end()) gone.push_back(place);
  return gone;
}

// glibc keeps what a thread frees in that thread's arena, and the service
// calls run on threads of their own: 150 places loaded and unloaded left 1.4
// to 1.8 GB with one place held (issue 38, R1), 162 MB after malloc_trim. So
// once the places that went are freed (a relocalization under way holds them
// until it ends: waited for, up to kReleaseWait), the freed memory goes back.
constexpr std::chrono::milliseconds kReleaseWait{2000};

void returnMemoryOf(const std::vector<std::weak_ptr<const relocalizer::Place>>& gone) {
  const auto give_up = std::chrono::steady_clock::now() + kReleaseWait;
  while (std::any_of(gone.begin(), gone.end(), [](const auto& p) { return !p.expired(); }) &&
         std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
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

relocalizer::Expected<std::unique_ptr<NodePlaces>> NodePlaces::create(
    const PlaceSettings& settings, const TfSettings& tf,
    const relocalizer::RelocalizerParams& relocalizer, LearnedModels learned) {
  const bool learn = static_cast<bool>(learned);
  std::unique_ptr<NodePlaces> places(
      new NodePlaces(tf, relocalizer, learn ? placeName(settings, learn) : "", std::move(learned)));
  std::vector<std::string> failures;
  for (const PlaceSpec& spec : startupPlaces(settings, learn, tf.map_frame)) {
    if (!spec.refused.empty()) {
      failures.push_back(spec.refused);
      continue;
    }
    auto loaded = loadPlaces(spec, relocalizer);
    if (!loaded) {
      failures.push_back(loaded.error());
      continue;
    }
    const std::vector<relocalizer::Place> places_of_spec = loaded->places;
    if (const relocalizer::Status put =
            relocalizer::putPlaceFiles(places->places_, spec.name, std::move(*loaded));
        !put)
      failures.push_back(put.error());
    else
      for (const relocalizer::Place& place : places_of_spec) warnLimitations(place);
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

NodePlaces::NodePlaces(const TfSettings& tf, const relocalizer::RelocalizerParams& relocalizer,
                       std::string learned_name, LearnedModels learned)
    : tf_(tf),
      relocalizer_(relocalizer),
      learned_name_(std::move(learned_name)),
      learned_(std::move(learned)) {}

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

bool NodePlaces::learnedName(const std::string& name) const {
  return isLearnedPlaceName(learned_name_, name);
}

void NodePlaces::followLearner() {
  if (!learned_) return;
  const std::vector<relocalizer::SubmapModel> models = learned_();
  std::vector<std::shared_ptr<const relocalizer::Relocalizer>> current;
  for (const relocalizer::SubmapModel& m : models) current.push_back(m.relocalizer);
  {
    std::lock_guard<std::mutex> lock(learned_mutex_);
    // Pointers, not contents: the learner swaps in a new model, never changes one.
    if (current == learned_models_) return;
    if (models.empty()) {
      learned_models_ = current;
      return;
    }
    if (const relocalizer::Status put = relocalizer::putLearnedPlaces(
            places_, models, {learned_name_, tf_.map_frame}, relocalizer::LoneSubmap::AsThePlace);
        !put) {
      // Not remembered as followed: the next frame tries again, so the learned
      // places answer as soon as what refused them (another place holding the
      // same model, say) is unloaded, not only after the next retrain.
      if (log_.allow(put.error()))
        ROS_WARN("relocalizer: the learned submaps: %s", put.error().c_str());
      return;
    }
    learned_models_ = current;
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

void NodePlaces::loadAndPut(const PlaceSpec& spec, relocalizer::LoadPlace::Response& response) {
  const std::vector<std::string> before = places_.names();
  const bool replaces = std::find(before.begin(), before.end(), spec.name) != before.end();
  // A peer's path: what cannot be opened as ours is refused in one wording.
  const std::string unreadable = relocalizer::unreadablePlaceError(spec.name, spec.model);
  auto loaded =
      unreadable.empty()
          ? loadPlaces(spec, relocalizer_)
          : relocalizer::Expected<relocalizer::PlaceFiles>(relocalizer::makeError(unreadable));
  const bool folder = loaded && loaded->folder;
  const std::vector<relocalizer::Place> places =
      loaded ? loaded->places : std::vector<relocalizer::Place>{};
  const relocalizer::Status put =
      loaded ? relocalizer::putPlaceFiles(places_, spec.name, std::move(*loaded))
             : relocalizer::Status(relocalizer::makeError(loaded.error()));
  response.success = put.ok();
  if (put) {
    if (changed_) changed_();
    for (const relocalizer::Place& place : places) warnLimitations(place);
    response.message = !folder ? std::string(replaces ? "replaced" : "loaded") + " place " +
                                     placeText(relocalizer::placeFigures(places[0]))
                               : "loaded " + std::to_string(places.size()) +
                                     " learned submaps of place '" + spec.name + "' in " +
                                     spec.map_frame + " (" + spec.model + ")";
  } else {
    response.message = put.error();
  }
}

bool NodePlaces::onLoad(relocalizer::LoadPlace::Request& request,
                        relocalizer::LoadPlace::Response& response) {
  response.success = false;
  PlaceSpec spec;
  spec.name = request.name;
  spec.map_frame = stripLeadingSlashes(request.map_frame);
  if (spec.map_frame.empty()) spec.map_frame = tf_.map_frame;
  // Relative to the node's working folder (ROS_HOME), which the caller does
  // not know: the answer names the file absolutely.
  std::error_code ignored;
  if (!request.model.empty())
    spec.model = std::filesystem::absolute(request.model, ignored).lexically_normal().string();
  if (spec.name.empty()) {
    response.message = "name is empty: name the place";
  } else if (std::string why = relocalizer::nameError(spec.name, "name"); !why.empty()) {
    response.message = why;
  } else if (std::string why = relocalizer::nameError(spec.map_frame, "map_frame"); !why.empty()) {
    response.message = why;
  } else if (spec.model.empty()) {
    response.message = "model is empty: name the model file of place '" + spec.name + "'";
  } else if (learnedName(spec.name)) {
    response.message = "'" + spec.name + "' is a name of the learned places; choose another name";
  } else if (!tf_.odom_frame.empty() && spec.map_frame == tf_.odom_frame) {
    response.message = "map_frame " + spec.map_frame + " is the odom_frame";
  } else {
    const auto gone = [&] {
      const auto before = places_.places();
      loadAndPut(spec, response);
      return goneFrom(before, places_);
    }();
    // What the load read (kept or refused) and what it replaced are freed by
    // now, or soon.
    returnMemoryOf(gone);
  }
  if (response.success)
    ROS_INFO("relocalizer: ~load_place: %s", response.message.c_str());
  else
    ROS_WARN("relocalizer: ~load_place refused: %s", response.message.c_str());
  return true;
}

bool NodePlaces::onUnload(relocalizer::UnloadPlace::Request& request,
                          relocalizer::UnloadPlace::Response& response) {
  response.success = false;
  if (std::string why = relocalizer::nameError(request.name, "name"); !why.empty()) {
    response.message = why + "; no place has such a name";
  } else if (learnedName(request.name)) {
    response.message = "'" + request.name + "' is a learned place; it follows the learner";
  } else {
    const auto gone = [&] {
      const auto before = places_.places();
      response.success = places_.remove(request.name);
      return goneFrom(before, places_);
    }();
    if (response.success && changed_) changed_();
    response.message = response.success ? "unloaded place '" + request.name + "'"
                                        : "no place named " + request.name;
    returnMemoryOf(gone);
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
    info.group = f.group;
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
