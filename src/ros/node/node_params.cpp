#include "node_params.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <nlohmann/json.hpp>

#include "relocalizer/core/config.h"
#include "relocalizer/core/outside_text.h"

namespace relocalizer_ros {

namespace {

using nlohmann::json;
using relocalizer::Expected;
using relocalizer::makeError;

Expected<json> toJson(XmlRpc::XmlRpcValue value, const std::string& name) {
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return json(static_cast<bool>(value));
    case XmlRpc::XmlRpcValue::TypeInt:
      return json(static_cast<int>(value));
    case XmlRpc::XmlRpcValue::TypeDouble:
      return json(static_cast<double>(value));
    case XmlRpc::XmlRpcValue::TypeString:
      return json(static_cast<std::string>(value));
    case XmlRpc::XmlRpcValue::TypeStruct: {
      json object = json::object();
      for (auto& entry : value) {
        auto child = toJson(entry.second, name + "/" + entry.first);
        if (!child) return child;
        object[entry.first] = std::move(*child);
      }
      return object;
    }
    default:
      return makeError("parameter '" + name + "' has an unsupported type");
  }
}

// The `relocalizer` sub-tree goes through the core's own config merge, so the
// node accepts exactly the keys and types that config files accept.
Expected<relocalizer::RelocalizerParams> readRelocalizerParams(const ros::NodeHandle& nh) {
  const relocalizer::RelocalizerParams defaults;
  if (!nh.hasParam("relocalizer")) return defaults;
  XmlRpc::XmlRpcValue tree;
  nh.getParam("relocalizer", tree);
  const std::string name = nh.resolveName("relocalizer");
  auto as_json = toJson(tree, name);
  if (!as_json) return makeError(as_json.error());
  // YAML is a superset of JSON, so the JSON text is a valid YAML document.
  auto merged = relocalizer::mergeYamlOntoJson(
      as_json->dump(), relocalizer::relocalizerParamsToJson(defaults), name);
  if (!merged) return makeError(merged.error());
  auto params = relocalizer::relocalizerParamsFromJson(*merged);
  if (!params) return makeError(name + ": " + params.error());
  return params;
}

// The place names and frames together: each a name (core/outside_text.h),
// unique names, no place in odom_frame.
std::string checkPlaces(const ParamReader& reader, const NodeParams& p) {
  const bool model_place = p.learn || !p.model.empty();
  const std::string own = placeName(p, p.learn);
  const std::string learned = p.learn ? own : "";
  const auto ns = [&reader](const std::string& key) { return reader.quoted(key); };
  for (auto [key, frame] : {std::pair{"map_frame", &p.map_frame},
                            {"odom_frame", &p.odom_frame},
                            {"handoff_frame", &p.handoff_frame}})
    if (!frame->empty())
      if (std::string why = relocalizer::nameError(*frame, ns(key)); !why.empty()) return why;
  // The learned place's name is learning's own: without it the node cannot
  // learn. A model's place with a bad name is one place that does not load.
  if (p.learn)
    if (std::string why = relocalizer::nameError(own, ns("place_name")); !why.empty())
      return why + (p.place_name.empty() ? " (the model file's stem; set place_name)" : "");
  for (size_t i = 0; i < p.places.size(); ++i) {
    const std::string entry =
        "'" + reader.handle().resolveName("places") + "[" + std::to_string(i) + "]'";
    if ((model_place && p.places[i].name == own) || isLearnedPlaceName(learned, p.places[i].name))
      return entry + " is named '" + p.places[i].name + "' like the place of " +
             (p.learn ? "learning (or its submaps, " + own + "/i)" : "model " + p.model) +
             "; set place_name to another name, or rename the entry";
    if (!p.odom_frame.empty() && p.places[i].map_frame == p.odom_frame)
      return entry + "'s map_frame equals odom_frame";
  }
  return {};
}

}  // namespace

Expected<NodeParams> loadNodeParams(const ros::NodeHandle& nh) {
  NodeParams p;
  ParamReader reader(nh);
  readTfSettings(reader, p);
  readPlaceSettings(reader, p.map_frame, p);
  readInputSettings(reader, p);
  readHintSettings(reader, p);
  reader.readInt("threads", p.threads, 0);
  readHandoffSettings(reader, p);
  readLearnSettings(reader, p);
  readDiagnosticSettings(reader, p);
  if (!reader.ok()) return makeError(reader.error());

  // What spans the parts: something to relocalize against, no learning from
  // the node's own TF, place names and frames that are names and do not clash.
  const auto ns = [&reader](const std::string& key) { return reader.quoted(key); };
  if (p.model.empty() && !p.learn && p.places.empty())
    return makeError(ns("model") +
                     " is not set (path to a model file from `train`; or places, or learn: true)");
  if (p.learn && p.publish_tf)
    return makeError(ns("learn") +
                     " is true but publish_tf is true too: the node would learn from "
                     "poses it published on TF itself; set publish_tf: false (SLAM owns " +
                     p.map_frame + " -> camera while learning)");
  if (std::string why = checkPlaces(reader, p); !why.empty()) return makeError(why);
  if (!p.learn && !p.model.empty())
    if (std::string why = relocalizer::nameError(placeName(p, p.learn), ns("place_name"));
        !why.empty())
      p.model_place_refused =
          "place of " + p.model + ": " + why +
          (p.place_name.empty() ? " (the model file's stem; set place_name)" : "");

  auto relocalizer_params = readRelocalizerParams(nh);
  if (!relocalizer_params) return makeError(relocalizer_params.error());
  p.relocalizer = *relocalizer_params;
  return p;
}

std::string nodeParamsToJson(const NodeParams& p) {
  json places = json::array();
  for (const PlaceSpec& place : p.places)
    places.push_back(
        {{"name", place.name}, {"model", place.model}, {"map_frame", place.map_frame}});
  json j = {{"model", p.model},
            {"place_name", p.place_name},
            {"places", places},
            {"mode", modeName(p.mode)},
            {"map_frame", p.map_frame},
            {"odom_frame", p.odom_frame},
            {"publish_tf", p.publish_tf},
            {"transform_tolerance", p.transform_tolerance},
            {"tf_rate", p.tf_rate},
            {"tf_timeout", p.tf_timeout},
            {"approx_sync", p.approx_sync},
            {"sync_queue_size", p.sync_queue_size},
            {"max_interval", p.max_interval},
            {"max_rate", p.max_rate},
            {"process_all", p.process_all},
            {"service_timeout", p.service_timeout},
            {"input_timeout", p.input_timeout},
            {"hint_timeout", p.hint_timeout},
            {"threads", p.threads},
            {"forward_initialpose", p.forward_initialpose},
            {"set_pose_service", p.set_pose_service},
            {"handoff_frame", p.handoff_frame},
            {"learn", p.learn},
            {"save_on_exit", p.save_on_exit},
            {"save_model_folder", p.save_model_folder},
            {"learn_min_motion", p.learn_min_motion},
            {"learn_max_keyframes", p.learn_max_keyframes},
            {"learn_submap_radius", p.learn_submap_radius},
            {"learn_submap_overlap", p.learn_submap_overlap},
            {"learn_cover_steps", p.learn_cover_steps},
            {"learn_relearn_agreement", p.learn_relearn_agreement},
            {"learn_first_retrain", p.learn_first_retrain},
            {"learn_retrain_growth", p.learn_retrain_growth},
            {"learn_surface_gate", p.learn_surface_gate},
            {"learn_slam_check", p.learn_slam_check},
            {"learn_max_slam_speed", p.learn_max_slam_speed},
            {"learn_slam_disagreement", p.learn_slam_disagreement},
            {"learn_config", p.learn_config},
            {"diagnostic_period", p.diagnostic_period},
            {"diagnostics_max_failures", p.diagnostics_max_failures},
            {"relocalizer", json::parse(relocalizer::relocalizerParamsToJson(p.relocalizer))}};
  return j.dump(2);
}

}  // namespace relocalizer_ros
