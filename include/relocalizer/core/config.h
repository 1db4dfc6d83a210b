#pragma once
// YAML configuration files (config/*.yaml) merged onto the compiled defaults.
// A key the program does not know, or a value of the wrong type, is an error
// naming the file and the key: a typo must not silently leave a default.

#include <string>

#include "relocalizer/core/expected.h"

namespace relocalizer {

// Merges a YAML document onto a JSON object of defaults, key by key, checking
// that every key exists and its type matches. Shared by every config reader.
Expected<std::string> mergeYamlOntoJson(const std::string& yaml_text,
                                        const std::string& defaults_json,
                                        const std::string& source);

}  // namespace relocalizer
