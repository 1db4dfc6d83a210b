// The YAML configuration readers: parseTrainingParams (config/forest.yaml,
// `train --config`) and mergeYamlOntoJson as the node's `relocalizer:` section
// uses it (RelocalizerParams defaults). Every outcome must be a value or an
// Error; an exception escaping is a crash here, as it would be in a tool.

#include <cstdint>
#include <cstdlib>
#include <string>

#include "relocalizer/core/config.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/forest/training_config.h"
#include "relocalizer/relocalize/relocalizer.h"

using namespace relocalizer;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string yaml(reinterpret_cast<const char*>(data), size);

  static const TrainingParams training_defaults;
  auto training = parseTrainingParams(yaml, "fuzz.yaml", training_defaults);
  if (training) {
    // What was accepted must survive the JSON form that model headers use.
    if (!trainingParamsFromJson(trainingParamsToJson(*training))) std::abort();
  }

  static const std::string relocalizer_defaults = relocalizerParamsToJson(RelocalizerParams{});
  auto merged = mergeYamlOntoJson(yaml, relocalizer_defaults, "fuzz.yaml");
  if (merged) {
    auto params = relocalizerParamsFromJson(*merged);
    if (params) (void)relocalizerParamsToJson(*params);
  }
  return 0;
}
