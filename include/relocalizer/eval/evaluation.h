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
  StageTimings timings;
};

// The record of one attempt: what relocalize() answered for a frame with ground truth.
EvaluationRecord recordAttempt(int id, double stamp, const Pose& truth,
                               const Relocalization& result);

struct LatencySummary {
  double median_ms = 0.0;
  double p95_ms = 0.0;
};

// Median and 95th percentile of one stage's time, in milliseconds.
LatencySummary stageLatency(const std::vector<StageTimings>& timings, double StageTimings::*stage);

struct EvaluationSummary {
  AccuracySummary accuracy;
  LatencySummary total, sampling, forest, ransac, refinement, surface;
};

EvaluationSummary summarizeEvaluation(const std::vector<EvaluationRecord>& records);
AccuracySummary summarizeAccuracy(const std::vector<EvaluationRecord>& records);

// The printed table (several lines, ends with a newline). `title` heads it.
std::string formatEvaluationTable(const EvaluationSummary& summary, const std::string& title);

struct EvaluationOutputOptions {
  bool integer_stamps = false;  // 7-Scenes: the stamp column is the frame number
  std::string title;            // for plots and the JSON
  std::string extra_json;       // an object merged into summary.json (model, params, ...)
};

// Writes poses.txt (TUM format, frames with a pose), errors.csv, summary.json,
// trajectory.png and errors.png into `folder` (created if missing).
Status writeEvaluationOutputs(const std::string& folder,
                              const std::vector<EvaluationRecord>& records,
                              const EvaluationSummary& summary,
                              const EvaluationOutputOptions& options);

}  // namespace relocalizer
