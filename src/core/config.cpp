#include "relocalizer/core/config.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

namespace relocalizer {

namespace {

using nlohmann::json;

// An integer parameter's value. A whole number written as a float (1e11; ROS
// parameters beyond XML-RPC's 32-bit integers arrive as doubles) or beyond
// long long is kept as a number, so that the reader's range check names the
// allowed range instead of calling it the wrong type; 2.5 is still wrong.
json integer(const YAML::Node& node) {
  try {
    return node.as<long long>();
  } catch (const YAML::Exception&) {
    const double v = node.as<double>();  // throws for text: the wrong type
    if (!std::isfinite(v) || v != std::floor(v)) throw;
    if (std::abs(v) < 9.2e18) return static_cast<long long>(v);  // within long long
    return v;
  }
}

// Overlays `node` onto `target`, which holds the defaults and so defines which
// keys and types are allowed.
std::string overlay(const YAML::Node& node, json& target, const std::string& path) {
  if (target.is_object()) {
    if (node.IsNull()) return {};
    if (!node.IsMap()) return "'" + path + "' must be a mapping";
    for (const auto& entry : node) {
      // A null, list or mapping key ("? [a, b]: 1") has no parameter name.
      if (!entry.first.IsScalar())
        return "'" + (path.empty() ? std::string("(top level)") : path) +
               "' has a key that is not a plain name";
      const std::string key = entry.first.Scalar();
      const std::string child = path.empty() ? key : path + "." + key;
      if (!target.contains(key)) return "unknown parameter '" + child + "'";
      const std::string why = overlay(entry.second, target[key], child);
      if (!why.empty()) return why;
    }
    return {};
  }
  if (!node.IsScalar()) return "'" + path + "' must be a single value";
  try {
    if (target.is_boolean()) {
      target = node.as<bool>();
    } else if (target.is_number_integer()) {  // signed or unsigned
      const json v = integer(node);
      if (target.is_number_unsigned() && v.get<double>() < 0)
        return "'" + path + "' must not be negative";
      target = v;
    } else if (target.is_number_float()) {
      // .nan and .inf, or a value beyond float range, cannot be a parameter and
      // would not survive the JSON a model header stores them in.
      const double v = node.as<double>();
      if (!std::isfinite(v) || std::abs(v) > std::numeric_limits<float>::max())
        return "'" + path + "' must be a finite number (got '" + node.Scalar() + "')";
      target = v;
    } else if (target.is_string()) {
      target = node.as<std::string>();
    } else {
      return "'" + path + "' has an unsupported type";
    }
  } catch (const YAML::Exception&) {
    return "'" + path + "' has the wrong type (got '" + node.Scalar() + "', expected " +
           std::string(target.type_name()) + ")";
  }
  return {};
}

}  // namespace

Expected<std::string> mergeYamlOntoJson(const std::string& yaml_text,
                                        const std::string& defaults_json,
                                        const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    return makeError(source + ": not valid YAML: " + e.what());
  }
  json merged = json::parse(defaults_json);
  const std::string why = overlay(root, merged, "");
  if (!why.empty()) return makeError(source + ": " + why);
  return merged.dump();
}

}  // namespace relocalizer
