#include "relocalizer/forest/training_config.h"

#include <fstream>
#include <sstream>

#include "relocalizer/core/config.h"
#include "relocalizer/forest/model_io.h"

namespace relocalizer {

Expected<TrainingParams> parseTrainingParams(const std::string& yaml_text,
                                             const std::string& source,
                                             const TrainingParams& defaults) {
  auto merged = mergeYamlOntoJson(yaml_text, trainingParamsToJson(defaults), source);
  if (!merged) return makeError(merged.error());
  auto params = trainingParamsFromJson(*merged);
  if (!params) return makeError(source + ": " + params.error());
  return params;
}

Expected<TrainingParams> loadTrainingParams(const std::string& path,
                                            const TrainingParams& defaults) {
  std::ifstream in(path);
  if (!in) return makeError(path + ": cannot open configuration file");
  std::stringstream text;
  text << in.rdbuf();
  return parseTrainingParams(text.str(), path, defaults);
}

}  // namespace relocalizer
