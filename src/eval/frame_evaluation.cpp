#include "relocalizer/eval/frame_evaluation.h"

#include <cstdio>
#include <functional>
#include <nlohmann/json.hpp>

#include "relocalizer/core/progress.h"
#include "relocalizer/core/statistics.h"

namespace relocalizer {

namespace {

Status addPredictionQuality(const Relocalizer& relocalizer, const RgbdFrame& frame,
                            FrameEvaluation& evaluation) {
  const Model& model = relocalizer.model();
  for (int lines = 0; lines < 2; ++lines) {
    if ((lines ? model.lines : model.points).empty()) continue;
    auto q = relocalizer.measurePredictions(frame, lines == 1);
    if (!q) return makeError(q.error());
    PredictionTotals& totals = evaluation.quality[lines];
    totals.samples += q->samples;
    totals.chosen_within += q->chosen_within;
    totals.any_within += q->any_within;
    totals.chosen_errors.insert(totals.chosen_errors.end(), q->chosen_errors.begin(),
                                q->chosen_errors.end());
  }
  return okStatus();
}

// Visits each selected frame that has ground truth, loaded, in order, with its
// hint when `hints` makes them (else nullptr); the others are counted as
// skipped. Fails on the first frame that does not load.
Status forEachPosedFrame(
    const FrameSource& source, const std::string& progress_label, FrameEvaluation& evaluation,
    SimulatedHints* hints,
    const std::function<Status(size_t, const RgbdFrame&, const PoseHint*)>& visit) {
  ProgressBar bar(progress_label, source.size());
  for (size_t i = 0; i < source.size(); ++i) {
    bar.advance();
    if (!source.groundTruth(i)) {
      ++evaluation.skipped;
      continue;
    }
    auto frame = source.load(i);
    if (!frame) return makeError(frame.error());
    PoseHint hint;
    if (hints) hint = hints->around(*source.groundTruth(i));
    if (Status visited = visit(i, *frame, hints ? &hint : nullptr); !visited) return visited;
  }
  return okStatus();
}

}  // namespace

Expected<FrameEvaluation> evaluateFrames(const Relocalizer& relocalizer, const FrameSource& source,
                                         bool measure_predictions,
                                         const std::string& progress_label, SimulatedHints* hints) {
  FrameEvaluation evaluation;
  const Status done = forEachPosedFrame(
      source, progress_label, evaluation, hints,
      [&](size_t i, const RgbdFrame& frame, const PoseHint* hint) -> Status {
        const Relocalization result = relocalizer.relocalize(frame, hint);
        if (measure_predictions)
          if (Status measured = addPredictionQuality(relocalizer, frame, evaluation); !measured)
            return measured;
        evaluation.records.push_back(
            recordAttempt(source.id(i), source.stamp(i), *source.groundTruth(i), result));
        return okStatus();
      });
  if (!done) return makeError(done.error());
  return evaluation;
}

Expected<FrameEvaluation> evaluateFrames(const PlaceSet& places, const FrameSource& source,
                                         const std::string& progress_label, SimulatedHints* hints) {
  FrameEvaluation evaluation;
  const Status done = forEachPosedFrame(
      source, progress_label, evaluation, hints,
      [&](size_t i, const RgbdFrame& frame, const PoseHint* hint) -> Status {
        evaluation.records.push_back(recordAttempt(
            source.id(i), source.stamp(i), *source.groundTruth(i), places.relocalize(frame, hint)));
        return okStatus();
      });
  if (!done) return makeError(done.error());
  return evaluation;
}

PredictionReport reportPredictionQuality(const FrameEvaluation& evaluation) {
  PredictionReport report;
  nlohmann::json json;
  for (int lines = 0; lines < 2; ++lines) {
    const PredictionTotals& q = evaluation.quality[lines];
    if (q.samples == 0) continue;
    std::vector<double> errors(q.chosen_errors.begin(), q.chosen_errors.end());
    const double chosen = 100.0 * q.chosen_within / q.samples;
    const double any = 100.0 * q.any_within / q.samples;
    char line[256];
    std::snprintf(line, sizeof line,
                  "  %s forest: %.1f %% of %ld predictions within 10 cm (nearest descriptor), "
                  "%.1f %% with some candidate within 10 cm, median error %.1f cm\n",
                  lines ? "line " : "point", chosen, q.samples, any, 100.0 * median(errors));
    report.text += line;
    json[lines ? "lines" : "points"] = {{"samples", q.samples},
                                        {"chosen_within_10cm", chosen / 100.0},
                                        {"any_within_10cm", any / 100.0},
                                        {"median_chosen_error_cm", 100.0 * median(errors)}};
  }
  report.json = json.dump();
  return report;
}

}  // namespace relocalizer
