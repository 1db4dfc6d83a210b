#pragma once
// Training parameters from a YAML file shaped like config/forest.yaml, merged
// onto the compiled defaults (core/config.h says how).

#include <string>

#include "relocalizer/core/expected.h"
#include "relocalizer/forest/training.h"

namespace relocalizer {

// Reads training parameters from a YAML file shaped like config/forest.yaml.
// Keys absent from the file keep the values in `defaults`.
Expected<TrainingParams> loadTrainingParams(const std::string& path,
                                            const TrainingParams& defaults = {});

// The same, from YAML text (`source` names it in errors).
Expected<TrainingParams> parseTrainingParams(const std::string& yaml_text,
                                             const std::string& source,
                                             const TrainingParams& defaults = {});

}  // namespace relocalizer
