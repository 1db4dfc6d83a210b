#pragma once
// Training parameters as JSON: the form model headers store them in and the
// YAML config merge works on (trainingParamsToJson / trainingParamsFromJson in
// model_io.h are the public face). Private to the forest module.

#include <nlohmann/json.hpp>

#include "relocalizer/forest/training.h"

namespace relocalizer::detail {

nlohmann::json trainingParamsJson(const TrainingParams& params);
// Fills `params` from `j`; throws on a missing or ill-typed field.
void readTrainingParams(const nlohmann::json& j, TrainingParams& params);

}  // namespace relocalizer::detail
