#pragma once
// Relocalizing every selected frame of a source (data/frame_source.h) with one
// model into evaluation records (evaluation.h), optionally measuring how good
// the forests' predictions are. `evaluate` and its learning curve share it.

#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/data/frame_source.h"
#include "relocalizer/eval/evaluation.h"
#include "relocalizer/eval/simulated_hints.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

// Forest predictions summed over frames (Relocalizer::measurePredictions, 10 cm).
struct PredictionTotals {
  long samples = 0;
  long chosen_within = 0;
  long any_within = 0;
  std::vector<float> chosen_errors;  // metres
};

struct FrameEvaluation {
  std::vector<EvaluationRecord> records;  // frames with ground truth, in order
  int skipped = 0;                        // frames without ground truth
  PredictionTotals quality[2];            // [0] point forest, [1] line forest
};

// `measure_predictions` adds the prediction quality of each forest the model
// has; `progress_label` names the progress bar; with `hints` every frame is
// relocalized with a hint near its ground truth. Fails on the first frame that
// does not load.
Expected<FrameEvaluation> evaluateFrames(const Relocalizer& relocalizer, const FrameSource& source,
                                         bool measure_predictions,
                                         const std::string& progress_label,
                                         SimulatedHints* hints = nullptr);

// The same against many places: each record names its answering place.
Expected<FrameEvaluation> evaluateFrames(const PlaceSet& places, const FrameSource& source,
                                         const std::string& progress_label,
                                         SimulatedHints* hints = nullptr);

// One printed line per measured forest, and the same as a JSON object
// ({"points": {...}, "lines": {...}}; "null" when nothing was measured).
struct PredictionReport {
  std::string text;
  std::string json;
};
PredictionReport reportPredictionQuality(const FrameEvaluation& evaluation);

}  // namespace relocalizer
