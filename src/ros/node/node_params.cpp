#include "node_params.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>

#include "../conversion/message_conversion.h"
#include "relocalizer/core/config.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/core/outside_text.h"

namespace relocalizer_ros {

namespace {

using nlohmann::json;
using relocalizer::makeError;

// Whole numbers in full (99999999999, not 1e+11): the user typed them so.
std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.15g", value);
  return text;
}

// roscpp's param() falls back to the default when the stored value has another
// type; a robot must not run on a default because of a quoting slip.
template <typename T>
std::string read(const ros::NodeHandle& nh, const std::string& key, T& value) {
  if (!nh.hasParam(key)) return {};
  if (!nh.getParam(key, value)) return "parameter '" + nh.resolveName(key) + "' has the wrong type";
  return {};
}

// XML-RPC integers are 32-bit: roscpp stores `_key:=99999999999` as a double
// (rosparam and roslaunch refuse it), so a whole number that arrives as a
// double is read as an integer, and beyond int it is out of range, not a value
// of the wrong type.
std::string readInt(const ros::NodeHandle& nh, const std::string& key, int& value, int min) {
  if (!nh.hasParam(key)) return {};
  const std::string range = "; it must be an integer from " + std::to_string(min) + " to " +
                            std::to_string(std::numeric_limits<int>::max());
  XmlRpc::XmlRpcValue stored;
  nh.getParam(key, stored);
  if (stored.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    const double d = static_cast<double>(stored);
    if (!std::isfinite(d) || d != std::floor(d))
      return "parameter '" + nh.resolveName(key) + "' has the wrong type";
    if (d < std::numeric_limits<int>::min() || d > std::numeric_limits<int>::max())
      return "parameter '" + nh.resolveName(key) + "' is " + number(d) + ", out of range" + range;
    value = static_cast<int>(d);
  } else if (!nh.getParam(key, value)) {
    return "parameter '" + nh.resolveName(key) + "' has the wrong type";
  }
  if (value < min)
    return "parameter '" + nh.resolveName(key) + "' is " + std::to_string(value) + range;
  return {};
}

// The duration and rate parameters and their bounds. Each bound is what a
// working configuration can want, and far inside what the values feed:
// ros::Duration and ros::WallDuration (|s| < 2^31, else the node aborts with
// "Duration is out of dual 32-bit range"), ros::Time + Duration, and the
// nanosecond std::chrono periods (< 9.2e9 s). Rates give periods 1/rate, so
// they need a lower bound too; 0 keeps its meaning (off, or no limit).
struct Bounded {
  const char* key;
  // A double of NodeParams; decltype, since clang-format 11-14 and 19 space the
  // `T::*` declarator differently.
  decltype(&NodeParams::tf_timeout) field;
  double min, max;
  const char* unit;
  const char* zero;  // what 0 means when min > 0, else nullptr
};

// tf2's default cache is 10 s: a map -> odom post-dated further outlives any
// consumer's history, and keeps a stale localization looking current.
constexpr double kMaxTransformTolerance = 10.0;
// A re-broadcast period longer than 100 s is ten times tf2's cache: its
// transforms have expired long before the next one; 0 says "only on updates"
// honestly. Faster than 1 kHz only floods /tf.
constexpr double kMinTfRate = 0.01, kMaxTfRate = 1000.0;
// The lookup blocks the worker or a service thread; SLAM 10 s late at a
// frame's stamp is not tracking it.
constexpr double kMaxTfTimeout = 10.0;
// Colour, depth and camera_info stamped more than 10 s apart are not one frame
// (0 already means no limit).
constexpr double kMaxSyncInterval = 10.0;
// Fewer than one relocalization in 1000 s is on_demand mode's job; one a
// millisecond is far beyond a relocalization's ~20 ms, so more is "0: no limit".
constexpr double kMinMaxRate = 0.001, kMaxMaxRate = 1000.0;
// The watchdog reports a silence; after an hour the report helps nobody (0: off).
constexpr double kMaxInputTimeout = 3600.0;
// A hint older than an hour describes a robot that has long moved on.
constexpr double kMinHintTimeout = 0.01, kMaxHintTimeout = 3600.0;

// /diagnostics: faster than 10 Hz floods the aggregators for nothing; a
// status older than a minute says nothing about the node now.
constexpr double kMinDiagnosticPeriod = 0.1, kMaxDiagnosticPeriod = 60.0;

constexpr Bounded kBounded[] = {
    {"transform_tolerance", &NodeParams::transform_tolerance, 0.0, kMaxTransformTolerance, "s",
     nullptr},
    {"tf_rate", &NodeParams::tf_rate, kMinTfRate, kMaxTfRate, "Hz", "only on updates"},
    {"tf_timeout", &NodeParams::tf_timeout, 0.0, kMaxTfTimeout, "s", nullptr},
    {"max_interval", &NodeParams::max_interval, 0.0, kMaxSyncInterval, "s", nullptr},
    {"max_rate", &NodeParams::max_rate, kMinMaxRate, kMaxMaxRate, "Hz", "no limit"},
    {"service_timeout", &NodeParams::service_timeout, 0.0, kMaxServiceWaitSeconds, "s", nullptr},
    {"input_timeout", &NodeParams::input_timeout, 0.0, kMaxInputTimeout, "s", nullptr},
    {"hint_timeout", &NodeParams::hint_timeout, kMinHintTimeout, kMaxHintTimeout, "s", nullptr},
    {"diagnostic_period", &NodeParams::diagnostic_period, kMinDiagnosticPeriod,
     kMaxDiagnosticPeriod, "s", nullptr},
};

std::string checkBounded(const ros::NodeHandle& nh, const NodeParams& p) {
  for (const Bounded& b : kBounded) {
    const double value = p.*b.field;
    if ((value >= b.min && value <= b.max) || (b.zero && value == 0.0)) continue;
    const std::string unit = std::string(" ") + b.unit;
    return "parameter '" + nh.resolveName(b.key) + "' is " + number(value) + unit +
           "; it must be " + (b.zero ? "0 (" + std::string(b.zero) + ") or " : std::string()) +
           "from " + number(b.min) + " to " + number(b.max) + unit;
  }
  return {};
}

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

constexpr const char* kPlaceForm = "{name: NAME, model: FILE, map_frame: FRAME (optional)}";

// One field of a `places` entry: absent is "", anything but a string an error.
std::string placeField(XmlRpc::XmlRpcValue& entry, const char* key, const std::string& entry_name,
                       std::string& value) {
  if (!entry.hasMember(key)) return {};
  if (entry[key].getType() != XmlRpc::XmlRpcValue::TypeString)
    return "'" + entry_name + "/" + key + "' must be a string";
  value = static_cast<std::string>(entry[key]);
  return {};
}

std::string placeEntry(XmlRpc::XmlRpcValue& entry, const std::string& entry_name,
                       const std::string& map_frame, PlaceSpec& place) {
  if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct)
    return "'" + entry_name + "' must be " + kPlaceForm;
  for (const auto& member : entry)
    if (member.first != "name" && member.first != "model" && member.first != "map_frame")
      return "'" + entry_name + "' has an unknown key '" + member.first + "'; expected " +
             kPlaceForm;
  for (auto [key, field] :
       {std::pair{"name", &place.name}, {"model", &place.model}, {"map_frame", &place.map_frame}})
    if (std::string why = placeField(entry, key, entry_name, *field); !why.empty()) return why;
  if (place.name.empty()) return "'" + entry_name + "' has no name; expected " + kPlaceForm;
  if (place.model.empty()) return "'" + entry_name + "' has no model; expected " + kPlaceForm;
  place.map_frame = stripLeadingSlashes(place.map_frame);
  if (place.map_frame.empty()) place.map_frame = map_frame;
  for (auto [key, field] : {std::pair{"name", &place.name}, {"map_frame", &place.map_frame}})
    if (place.refused.empty())
      place.refused = relocalizer::nameError(*field, "'" + entry_name + "/" + key + "'");
  return {};
}

// `places`: a list of {name, model, map_frame}. A typo in a key or a name used
// twice is refused, never a place silently missing or shadowed.
Expected<std::vector<PlaceSpec>> readPlaces(const ros::NodeHandle& nh,
                                            const std::string& map_frame) {
  std::vector<PlaceSpec> places;
  if (!nh.hasParam("places")) return places;
  const std::string name = nh.resolveName("places");
  XmlRpc::XmlRpcValue list;
  nh.getParam("places", list);
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray)
    return makeError("parameter '" + name + "' must be a list of " + kPlaceForm);
  for (int i = 0; i < list.size(); ++i) {
    const std::string entry_name = name + "[" + std::to_string(i) + "]";
    PlaceSpec place;
    if (std::string why = placeEntry(list[i], entry_name, map_frame, place); !why.empty())
      return makeError(why);
    for (size_t j = 0; j < places.size(); ++j)
      if (places[j].name == place.name)
        return makeError("'" + entry_name + "' is named '" + place.name + "' like places[" +
                         std::to_string(j) + "]; place names must be unique");
    places.push_back(std::move(place));
  }
  return places;
}

// The place names and frames together: each a name (core/outside_text.h),
// unique names, no place in odom_frame.
std::string checkPlaces(const ros::NodeHandle& nh, const NodeParams& p) {
  const bool model_place = p.learn || !p.model.empty();
  const std::string own = placeName(p);
  const auto ns = [&nh](const std::string& key) { return "'" + nh.resolveName(key) + "'"; };
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
    const std::string entry = "'" + nh.resolveName("places") + "[" + std::to_string(i) + "]'";
    if ((model_place && p.places[i].name == own) || isLearnedPlaceName(p, p.places[i].name))
      return entry + " is named '" + p.places[i].name + "' like the place of " +
             (p.learn ? "learning (or its submaps, " + own + "/i)" : "model " + p.model) +
             "; set place_name to another name, or rename the entry";
    if (!p.odom_frame.empty() && p.places[i].map_frame == p.odom_frame)
      return entry + "'s map_frame equals odom_frame";
  }
  return {};
}

}  // namespace

std::string placeName(const NodeParams& params) {
  if (!params.place_name.empty()) return params.place_name;
  if (params.learn) return "learned";
  return relocalizer::pathStem(params.model);
}

bool isLearnedPlaceName(const NodeParams& params, const std::string& name) {
  if (!params.learn) return false;
  const std::string own = placeName(params);
  return name == own || name.rfind(own + "/", 0) == 0;
}

std::vector<PlaceSpec> startupPlaces(const NodeParams& params) {
  std::vector<PlaceSpec> places = params.places;
  if (!params.learn && !params.model.empty())
    places.push_back(
        {placeName(params), params.model, params.map_frame, params.model_place_refused});
  return places;
}

const char* modeName(Mode mode) { return mode == Mode::OnDemand ? "on_demand" : "continuous"; }

Expected<NodeParams> loadNodeParams(const ros::NodeHandle& nh) {
  NodeParams p;
  std::string mode = modeName(p.mode);
  std::string why;
  auto check = [&why](std::string error) {
    if (why.empty()) why = std::move(error);
  };
  check(read(nh, "model", p.model));
  check(read(nh, "place_name", p.place_name));
  check(read(nh, "mode", mode));
  check(read(nh, "map_frame", p.map_frame));
  check(read(nh, "odom_frame", p.odom_frame));
  check(read(nh, "publish_tf", p.publish_tf));
  check(read(nh, "transform_tolerance", p.transform_tolerance));
  check(read(nh, "tf_rate", p.tf_rate));
  check(read(nh, "tf_timeout", p.tf_timeout));
  check(read(nh, "approx_sync", p.approx_sync));
  check(readInt(nh, "sync_queue_size", p.sync_queue_size, 1));
  check(read(nh, "max_interval", p.max_interval));
  check(read(nh, "max_rate", p.max_rate));
  check(read(nh, "process_all", p.process_all));
  check(read(nh, "service_timeout", p.service_timeout));
  check(read(nh, "input_timeout", p.input_timeout));
  check(read(nh, "hint_timeout", p.hint_timeout));
  check(readInt(nh, "threads", p.threads, 0));
  check(read(nh, "forward_initialpose", p.forward_initialpose));
  check(read(nh, "set_pose_service", p.set_pose_service));
  check(read(nh, "handoff_frame", p.handoff_frame));
  check(read(nh, "learn", p.learn));
  check(read(nh, "save_on_exit", p.save_on_exit));
  check(read(nh, "save_model_folder", p.save_model_folder));
  check(read(nh, "learn_min_motion", p.learn_min_motion));
  check(readInt(nh, "learn_max_keyframes", p.learn_max_keyframes, 2));
  check(read(nh, "learn_submap_radius", p.learn_submap_radius));
  check(readInt(nh, "learn_submap_overlap", p.learn_submap_overlap, 0));
  check(read(nh, "learn_cover_steps", p.learn_cover_steps));
  check(readInt(nh, "learn_first_retrain", p.learn_first_retrain, 1));
  check(read(nh, "learn_retrain_growth", p.learn_retrain_growth));
  check(read(nh, "learn_surface_gate", p.learn_surface_gate));
  check(read(nh, "learn_slam_check", p.learn_slam_check));
  check(read(nh, "learn_max_slam_speed", p.learn_max_slam_speed));
  check(read(nh, "learn_slam_disagreement", p.learn_slam_disagreement));
  check(read(nh, "learn_config", p.learn_config));
  check(read(nh, "diagnostic_period", p.diagnostic_period));
  check(readInt(nh, "diagnostics_max_failures", p.diagnostics_max_failures, 0));
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
  p.handoff_frame = stripLeadingSlashes(p.handoff_frame);
  auto places = readPlaces(nh, p.map_frame);
  if (!places) return makeError(places.error());
  p.places = std::move(*places);
  if (p.model.empty() && !p.learn && p.places.empty())
    return makeError(ns("model") +
                     " is not set (path to a model file from `train`; or places, or learn: true)");
  if (p.learn && p.publish_tf)
    return makeError(ns("learn") +
                     " is true but publish_tf is true too: the node would learn from "
                     "poses it published on TF itself; set publish_tf: false (SLAM owns " +
                     p.map_frame + " -> camera while learning)");
  if (!p.learn && !p.save_on_exit.empty())
    return makeError(ns("save_on_exit") +
                     " is set but learn is false: only a learned model is saved");
  if (p.learn) {
    relocalizer::LearningParams learning;
    learning.max_keyframes = p.learn_max_keyframes;
    learning.first_retrain = p.learn_first_retrain;
    learning.retrain_growth = p.learn_retrain_growth;
    learning.surface_gate = p.learn_surface_gate;
    const relocalizer::SettingName name = [&](const std::string& field) {
      if (field == "config") return ns("learn_config");
      if (field == "area_radius") return ns("learn_submap_radius");
      if (field == "overlap") return ns("learn_submap_overlap");
      return ns("learn_" + field);
    };
    learning.slam_check.enabled = p.learn_slam_check;
    if (relocalizer::Status bounds = relocalizer::readSlamCheckBounds(
            p.learn_max_slam_speed, p.learn_slam_disagreement, learning.slam_check, name);
        !bounds)
      return makeError(bounds.error());
    auto checked =
        relocalizer::readLearningParams(learning, p.learn_min_motion, p.learn_config, name);
    if (!checked) return makeError(checked.error());
    p.learning = *checked;
    p.submaps.area_radius = p.learn_submap_radius;
    p.submaps.overlap = p.learn_submap_overlap;
    p.submaps.cover_steps = p.learn_cover_steps;
    if (std::string why = relocalizer::submapParamsError(p.submaps, p.learning.max_keyframes, name);
        !why.empty())
      return makeError(why);
  }
  if (p.map_frame.empty()) return makeError(ns("map_frame") + " is empty");
  if (p.odom_frame == p.map_frame) return makeError(ns("odom_frame") + " equals map_frame");
  if (std::string why = checkPlaces(nh, p); !why.empty()) return makeError(why);
  if (!p.learn && !p.model.empty())
    if (std::string why = relocalizer::nameError(placeName(p), ns("place_name")); !why.empty())
      p.model_place_refused =
          "place of " + p.model + ": " + why +
          (p.place_name.empty() ? " (the model file's stem; set place_name)" : "");
  if (std::string why = checkBounded(nh, p); !why.empty()) return makeError(why);

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
