#include "node_params.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <nlohmann/json.hpp>

#include "key_frames.h"
#include "message_conversion.h"
#include "relocalizer/core/config.h"

namespace relocalizer_ros {

namespace {

using nlohmann::json;
using relocalizer::makeError;

// roscpp's param() falls back to the default when the stored value has another
// type; a robot must not run on a default because of a quoting slip.
template <typename T>
std::string read(const ros::NodeHandle& nh, const std::string& key, T& value) {
  if (!nh.hasParam(key)) return {};
  if (!nh.getParam(key, value))
    return "parameter '" + nh.resolveName(key) + "' has the wrong type";
  return {};
}

Expected<json> toJson(XmlRpc::XmlRpcValue value, const std::string& name) {
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean: return json(static_cast<bool>(value));
    case XmlRpc::XmlRpcValue::TypeInt: return json(static_cast<int>(value));
    case XmlRpc::XmlRpcValue::TypeDouble: return json(static_cast<double>(value));
    case XmlRpc::XmlRpcValue::TypeString: return json(static_cast<std::string>(value));
    case XmlRpc::XmlRpcValue::TypeStruct: {
      json object = json::object();
      for (auto& entry : value) {
        auto child = toJson(entry.second, name + "/" + entry.first);
        if (!child) return child;
        object[entry.first] = std::move(*child);
      }
      return object;
    }
    default: return makeError("parameter '" + name + "' has an unsupported type");
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
  auto merged =
      relocalizer::mergeYamlOntoJson(as_json->dump(), relocalizer::relocalizerParamsToJson(defaults), name);
  if (!merged) return makeError(merged.error());
  return relocalizer::relocalizerParamsFromJson(*merged);
}

}  // namespace

const char* modeName(Mode mode) { return mode == Mode::OnDemand ? "on_demand" : "continuous"; }

Expected<NodeParams> loadNodeParams(const ros::NodeHandle& nh) {
  NodeParams p;
  std::string mode = modeName(p.mode);
  std::string why;
  auto check = [&why](std::string error) {
    if (why.empty()) why = std::move(error);
  };
  check(read(nh, "model", p.model));
  check(read(nh, "mode", mode));
  check(read(nh, "map_frame", p.map_frame));
  check(read(nh, "odom_frame", p.odom_frame));
  check(read(nh, "publish_tf", p.publish_tf));
  check(read(nh, "transform_tolerance", p.transform_tolerance));
  check(read(nh, "tf_rate", p.tf_rate));
  check(read(nh, "tf_timeout", p.tf_timeout));
  check(read(nh, "approx_sync", p.approx_sync));
  check(read(nh, "sync_queue_size", p.sync_queue_size));
  check(read(nh, "max_interval", p.max_interval));
  check(read(nh, "max_rate", p.max_rate));
  check(read(nh, "process_all", p.process_all));
  check(read(nh, "service_timeout", p.service_timeout));
  check(read(nh, "input_timeout", p.input_timeout));
  check(read(nh, "threads", p.threads));
  check(read(nh, "learn", p.learn));
  check(read(nh, "save_on_exit", p.save_on_exit));
  check(read(nh, "learn_min_motion", p.learn_min_motion));
  check(read(nh, "learn_max_keyframes", p.learn_max_keyframes));
  check(read(nh, "learn_first_retrain", p.learn_first_retrain));
  check(read(nh, "learn_retrain_growth", p.learn_retrain_growth));
  check(read(nh, "learn_surface_gate", p.learn_surface_gate));
  check(read(nh, "learn_config", p.learn_config));
  if (!why.empty()) return makeError(why);

  auto ns = [&nh](const std::string& key) { return "'" + nh.resolveName(key) + "'"; };
  if (mode == "on_demand") {
    p.mode = Mode::OnDemand;
  } else if (mode == "continuous") {
    p.mode = Mode::Continuous;
  } else {
    return makeError(ns("mode") + " is '" + mode + "'; expected on_demand or continuous");
  }
  p.map_frame = stripLeadingSlashes(p.map_frame);
  p.odom_frame = stripLeadingSlashes(p.odom_frame);
  if (p.model.empty() && !p.learn)
    return makeError(ns("model") + " is not set (path to a model file from `train`, or learn: true)");
  if (p.learn && p.publish_tf)
    return makeError(ns("learn") + " is true but publish_tf is true too: the node would learn from "
                     "poses it published on TF itself; set publish_tf: false (SLAM owns " +
                     p.map_frame + " -> camera while learning)");
  if (!p.learn && !p.save_on_exit.empty())
    return makeError(ns("save_on_exit") + " is set but learn is false: only a learned model is saved");
  if (p.learn) {
    if (auto motion = parseMinMotion(p.learn_min_motion); !motion)
      return makeError(ns("learn_min_motion") + ": " + motion.error());
    if (p.learn_max_keyframes < 2) return makeError(ns("learn_max_keyframes") + " must be at least 2");
    if (p.learn_first_retrain < 1 || p.learn_first_retrain > p.learn_max_keyframes)
      return makeError(ns("learn_first_retrain") + " must be between 1 and learn_max_keyframes");
    if (!(p.learn_retrain_growth >= 0.0) || !std::isfinite(p.learn_retrain_growth))
      return makeError(ns("learn_retrain_growth") + " must be a finite share >= 0");
  }
  if (p.map_frame.empty()) return makeError(ns("map_frame") + " is empty");
  if (p.odom_frame == p.map_frame) return makeError(ns("odom_frame") + " equals map_frame");
  if (p.sync_queue_size < 1) return makeError(ns("sync_queue_size") + " must be at least 1");
  for (const auto& [key, value] : {std::pair{"transform_tolerance", p.transform_tolerance},
                                   {"tf_rate", p.tf_rate},
                                   {"tf_timeout", p.tf_timeout},
                                   {"max_interval", p.max_interval},
                                   {"max_rate", p.max_rate},
                                   {"service_timeout", p.service_timeout},
                                   {"input_timeout", p.input_timeout}})
    if (!(value >= 0.0) || !std::isfinite(value))
      return makeError(ns(key) + " must be finite and not negative (got " + std::to_string(value) + ")");
  if (p.threads < 0) return makeError(ns("threads") + " must not be negative");

  auto relocalizer_params = readRelocalizerParams(nh);
  if (!relocalizer_params) return makeError(relocalizer_params.error());
  p.relocalizer = *relocalizer_params;
  return p;
}

std::string nodeParamsToJson(const NodeParams& p) {
  json j = {{"model", p.model},
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
            {"threads", p.threads},
            {"learn", p.learn},
            {"save_on_exit", p.save_on_exit},
            {"learn_min_motion", p.learn_min_motion},
            {"learn_max_keyframes", p.learn_max_keyframes},
            {"learn_first_retrain", p.learn_first_retrain},
            {"learn_retrain_growth", p.learn_retrain_growth},
            {"learn_surface_gate", p.learn_surface_gate},
            {"learn_config", p.learn_config},
            {"relocalizer", json::parse(relocalizer::relocalizerParamsToJson(p.relocalizer))}};
  return j.dump(2);
}

}  // namespace relocalizer_ros
