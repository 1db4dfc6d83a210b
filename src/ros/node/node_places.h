#pragma once
// The places the node relocalizes against (relocalize/place_set.h) and the
// services that change them at run time: ~load_place, ~unload_place,
// ~list_places. The services run on the node's service-call queue, a thread
// per call, so a model that takes seconds to load never holds up a
// relocalization: those work on the places as they were when they started.
//
// In learn mode the learner's submaps are places of one group, placeName()
// (place_settings.h), in map_frame (place_set.h: their answers that agree are
// one answer), put again all at once whenever the learner swaps in a new
// model or starts a submap. While only the first submap has a model it is
// the place placeName() itself, as before submaps; from the second on they
// are placeName()/0, placeName()/1, ...

#include <relocalizer/ListPlaces.h>
#include <relocalizer/LoadPlace.h>
#include <relocalizer/UnloadPlace.h>
#include <ros/ros.h>

#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "place_settings.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/online/submap_learner.h"
#include "relocalizer/relocalize/place_set.h"
#include "service_call_queue.h"
#include "tf_settings.h"
#include "throttled_log.h"

namespace relocalizer_ros {

class NodePlaces {
 public:
  // The learner's submap models now (SubmapLearner::models()).
  using LearnedModels = std::function<std::vector<relocalizer::SubmapModel>()>;

  // Loads the start-up places (startupPlaces()), in tf.map_frame when they
  // name no frame of their own. One that does not load is logged as an error
  // naming the place, the file and why, and the others keep working; when
  // none loads and `learned` is empty (not learn mode), the error says why
  // each failed.
  static relocalizer::Expected<std::unique_ptr<NodePlaces>> create(
      const PlaceSettings& settings, const TfSettings& tf,
      const relocalizer::RelocalizerParams& relocalizer, LearnedModels learned);

  // Advertises the three services on `calls`.
  void advertise(ros::NodeHandle private_nh, ServiceCallQueue& calls);
  void shutdown();

  // Against every place, the learned one as it is now included.
  relocalizer::PlaceAnswer relocalize(const relocalizer::RgbdFrame& frame,
                                      const relocalizer::PoseHint* hint = nullptr);
  // The places now, each with its figures (learned one included).
  std::vector<relocalizer::PlaceFigures> list();
  bool empty();
  bool learning() const { return static_cast<bool>(learned_); }
  // The places now (the learned one as last put), for those who draw them.
  std::vector<std::shared_ptr<const relocalizer::Place>> places() const { return places_.places(); }
  // Called after every change of the places (load, unload, a new learned
  // model), on the thread that made it. Set before advertise().
  void onChange(std::function<void()> changed) { changed_ = std::move(changed); }

 private:
  NodePlaces(const TfSettings& tf, const relocalizer::RelocalizerParams& relocalizer,
             std::string learned_name, LearnedModels learned);
  // Puts the learner's models into the set when they changed since the last look.
  void followLearner();
  // A name of the learned group's (placeName(), or placeName()/i).
  bool learnedName(const std::string& name) const;
  // Loads the spec's model or folder and puts it, saying how in `response`.
  void loadAndPut(const PlaceSpec& spec, relocalizer::LoadPlace::Response& response);
  bool onLoad(relocalizer::LoadPlace::Request& request, relocalizer::LoadPlace::Response& response);
  bool onUnload(relocalizer::UnloadPlace::Request& request,
                relocalizer::UnloadPlace::Response& response);
  bool onList(relocalizer::ListPlaces::Request& request,
              relocalizer::ListPlaces::Response& response);

  // Copies: the node's own are moved in after create().
  const TfSettings tf_;
  const relocalizer::RelocalizerParams relocalizer_;
  const std::string learned_name_;  // "" unless learn mode
  const LearnedModels learned_;     // empty unless learn mode
  relocalizer::PlaceSet places_;
  std::mutex learned_mutex_;
  std::vector<std::shared_ptr<const relocalizer::Relocalizer>> learned_models_;  // as last put
  ThrottledLog log_;
  ros::ServiceServer load_service_, unload_service_, list_service_;
  std::function<void()> changed_;
};

// What a listing says of a place, as ~list_places and the start-up log show it.
std::string placeText(const relocalizer::PlaceFigures& figures);

}  // namespace relocalizer_ros
