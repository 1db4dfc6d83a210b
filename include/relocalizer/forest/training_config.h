#pragma once
// YAML configuration files (config/*.yaml) merged onto the compiled defaults.
// A key the program does not know, or a value of the wrong type, is an error
// naming the file and the key: a typo must not silently leave a default.

#include <string>

#include "relocalizer/expected.h"
#include "relocalizer/training.h"

namespace relocalizer {

// Reads training parameters from a YAML file shaped like config/forest.yaml.
// Keys absent from the file keep the values in `defaults`.
Expected<TrainingParams> loadTrainingParams(const std::string& path,
                                            const TrainingParams& defaults = {});

// The same, from YAML text (`source` names it in errors).
Expected<TrainingParams> parseTrainingParams(const std::string& yaml_text, const std::string& source,
                                             const TrainingParams& defaults = {});

// Merges a YAML document onto a JSON object of defaults, key by key, checking
// that every key exists and its type matches. Shared by every config reader.
Expected<std::string> mergeYamlOntoJson(const std::string& yaml_text, const std::string& defaults_json,
                                        const std::string& source);

}  // namespace relocalizer
