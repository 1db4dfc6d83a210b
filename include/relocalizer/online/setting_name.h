#pragma once
// How a reader names a learning setting to its user, from its field name
// ("max_keyframes"): the node says 'learn_max_keyframes' with its namespace,
// the tools their option. Unset: the field name.

#include <functional>
#include <string>

namespace relocalizer {

using SettingName = std::function<std::string(const std::string& field)>;

// `field` as `name` calls it, or as it is when no name is given.
inline std::string settingName(const SettingName& name, const std::string& field) {
  return name ? name(field) : field;
}

}  // namespace relocalizer
