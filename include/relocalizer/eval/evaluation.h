#pragma once
// An evaluation run: per-frame records in, the literature's table and the
// files a researcher compares (poses.txt, errors.csv, summary.json, plots) out.
// The offline `evaluate` tool and the rosbag replay share it, so their numbers
// mean the same thing.

#include <optional>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/eval/metrics.h"
#include "relocalizer/relocalize/place_set.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

struct EvaluationRecord {
  int id = -1;
  double stamp = 0.0;
  Pose truth = Pose::Identity();
  std::optional<Pose> estimate;  // empty: no pose
  std::string message;           // the reason, without a pose
  int point_inliers = 0;
  int line_inliers = 0;
  float score = 0.0f;
  float surface_agreement = -1.0f;  // < 0: not checked
  float light_cast = 0.0f;          // > 0: asked again in the training light (light_retry.h)
  bool second_draw = false;         // weak, so drawn again to confirm it (second_draw.h)
  StageTimings timings;
  std::string place;  // the answering place, with many places; empty: no pose, or one place
};

// The record of one attempt: what relocalize() answered for a frame with ground truth.
EvaluationRecord recordAttempt(int id, double stamp, const Pose& truth,
                               const Relocalization& result);
EvaluationRecord recordAttempt(int id, double stamp, const Pose& truth, const PlaceAnswer& answer);

// Answers from another place than `expected` (frames without a pose are no answer).
int countWrongPlace(const std::vector<EvaluationRecord>& records, const std::string& expected);

struct LatencySummary {
  double median_ms = 0.0;
  double p95_ms = 0.0;
};

// Median and 95th percentile of one stage's time, in milliseconds.
LatencySummary stageLatency(const std::vector<StageTimings>& timings, StageTimingsField stage);

struct EvaluationSummary {
  AccuracySummary accuracy;
  LatencySummary total, sampling, forest, ransac, refinement, surface, screening;
  std::string expected_place;  // with many places: where the frames were taken
  int wrong_place = -1;        // answers from another place; -1: not counted
  // Frames asked again in the training light (light_retry.h), and how many of
  // them got a pose that way.
  int asked_in_training_light = 0, answered_in_training_light = 0;
  // Answers too weak to give unconfirmed (second_draw.h), and how many of them
  // the second draw confirmed.
  int drawn_again = 0, confirmed_by_second_draw = 0;
};

// `expected_place` (many places): count the answers from any other place.
EvaluationSummary summarizeEvaluation(const std::vector<EvaluationRecord>& records,
                                      const std::string& expected_place = {});
AccuracySummary summarizeAccuracy(const std::vector<EvaluationRecord>& records);

// The printed table (several lines, ends with a newline). `title` heads it.
std::string formatEvaluationTable(const EvaluationSummary& summary, const std::string& title);

struct EvaluationOutputOptions {
  bool integer_stamps = false;  // 7-Scenes: the stamp column is the frame number
  std::string title;            // for plots and the JSON
  std::string extra_json;       // an object merged into summary.json (model, params, ...)
  bool places = false;          // many places: places.csv and the screening latency
};

// Writes poses.txt (TUM format, frames with a pose), errors.csv, summary.json,
// trajectory.png and errors.png into `folder` (created if missing); with
// `places`, also places.csv (each frame's stamp column as in poses.txt, then
// the answering place, empty for no pose).
Status writeEvaluationOutputs(const std::string& folder,
                              const std::vector<EvaluationRecord>& records,
                              const EvaluationSummary& summary,
                              const EvaluationOutputOptions& options);

}  // namespace relocalizer
