// evaluate: relocalizes every selected frame of a dataset (a folder or a rosbag)
// with a trained model and reports accuracy and latency as the relocalization
// literature does.

#include <filesystem>
#include <nlohmann/json.hpp>

#include "cli_support.h"
#include "frame_source.h"
#include "relocalizer/core/progress.h"
#include "relocalizer/core/statistics.h"
#include "relocalizer/core/version.h"
#include "relocalizer/eval/evaluation.h"
#include "relocalizer/pose/relocalizer.h"

using namespace relocalizer;

int main(int argc, char** argv) {
  CLI::App app{
      "Relocalizes each selected frame of a dataset independently and prints the share within "
      "5 cm / 5 deg and 2 cm / 2 deg, median errors, ATE RMSE, frames without a pose and latency "
      "per stage. With --output it writes poses.txt (TUM format), errors.csv, summary.json, "
      "trajectory.png and errors.png. The frames and their ground truth come from a dataset folder "
      "(--dataset) or a rosbag (--bag) with the same pose source as train --bag.",
      "evaluate"};
  std::string model_path, output, config, forests = "both";
  int threads = 0;
  bool prediction_quality = false;
  app.add_option("-m,--model", model_path, "Model file written by train")->required();
  cli::SourceOptions source_options;
  source_options.add(app, "Dataset folder with ground truth",
                     "Frame ids to evaluate, e.g. 100-199,300-399 (default: all); for a bag, ids "
                     "are indices in its synchronized frame order");
  app.add_option("-o,--output", output, "Folder for poses.txt, errors.csv, summary.json, plots");
  app.add_option("-c,--config", config,
                 "YAML file whose 'relocalizer:' section overrides the defaults (config/default.yaml)");
  app.add_option("--forests", forests, "points | lines | both")
      ->check(CLI::IsMember({"points", "lines", "both"}))
      ->capture_default_str();
  app.add_option("-j,--threads", threads, "Worker threads inside each call (0 = every core)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  app.add_flag("--prediction-quality", prediction_quality,
               "Also report the share of forest predictions within 10 cm of the truth");
  if (const int code = cli::parse(app, argc, argv); code >= 0) return code;

  RelocalizerParams params;
  if (!config.empty()) {
    auto loaded = loadRelocalizerParams(config);
    if (!loaded) return cli::fail(app, loaded.error());
    params = *loaded;
  }
  params.use_points = forests != "lines";
  params.use_lines = forests != "points";

  auto source = source_options.open();
  if (!source) return cli::fail(app, source.error());
  const cli::FrameSource& data = **source;
  const std::string& dataset_path = data.path();

  auto relocalizer = Relocalizer::fromFile(model_path, params);
  if (!relocalizer) return cli::fail(app, relocalizer.error());
  std::printf("%s\n", data.summary().c_str());
  const Model& model = (*relocalizer)->model();
  std::printf("model %s: %zu point trees, %zu line trees, trained on %d images of %s\n",
              model_path.c_str(), model.points.trees.size(), model.lines.trees.size(),
              model.summary.images, model.summary.dataset.c_str());
  if (const std::string limits = (*relocalizer)->limitations(); !limits.empty())
    std::printf("warning: %s\n", limits.c_str());

  const int thread_count = cli::resolveThreads(threads);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, thread_count);

  std::vector<EvaluationRecord> records;
  int skipped = 0;
  // Prediction quality per forest, summed over frames: samples, chosen within 10 cm, any within.
  long quality[2][3] = {{0, 0, 0}, {0, 0, 0}};
  std::vector<float> chosen_errors[2];
  {
    ProgressBar bar("evaluating", data.size());
    for (size_t i = 0; i < data.size(); ++i) {
      bar.advance();
      if (!data.groundTruth(i)) {
        ++skipped;
        continue;
      }
      auto frame = data.load(i);
      if (!frame) return cli::fail(app, frame.error());
      const Relocalization result = (*relocalizer)->relocalize(*frame);
      for (int lines = 0; prediction_quality && lines < 2; ++lines) {
        if ((lines ? model.lines : model.points).empty()) continue;
        auto q = (*relocalizer)->measurePredictions(*frame, lines == 1);
        if (!q) return cli::fail(app, q.error());
        quality[lines][0] += q->samples;
        quality[lines][1] += q->chosen_within;
        quality[lines][2] += q->any_within;
        chosen_errors[lines].insert(chosen_errors[lines].end(), q->chosen_errors.begin(), q->chosen_errors.end());
      }
      EvaluationRecord r;
      r.id = data.id(i);
      r.stamp = data.stamp(i);
      r.truth = *data.groundTruth(i);
      if (result.success) r.estimate = result.pose;
      r.message = result.message;
      r.point_inliers = result.point_inliers;
      r.line_inliers = result.line_inliers;
      r.score = result.score;
      r.surface_agreement = result.surface_agreement;
      r.timings = result.timings;
      records.push_back(std::move(r));
    }
  }
  if (records.empty()) return cli::fail(app, dataset_path + ": no selected frame has ground truth");
  if (skipped) std::printf("skipped %d frames without ground truth\n", skipped);

  const EvaluationSummary summary = summarizeEvaluation(records);
  const std::string title = "evaluate: " + forests + " forests, " + std::to_string(thread_count) +
                            (thread_count == 1 ? " thread" : " threads");
  std::printf("\n%s", formatEvaluationTable(summary, title).c_str());

  nlohmann::json quality_json;
  for (int lines = 0; prediction_quality && lines < 2; ++lines) {
    if (quality[lines][0] == 0) continue;
    std::vector<double> errors(chosen_errors[lines].begin(), chosen_errors[lines].end());
    const double chosen = 100.0 * quality[lines][1] / quality[lines][0];
    const double any = 100.0 * quality[lines][2] / quality[lines][0];
    std::printf("  %s forest: %.1f %% of %ld predictions within 10 cm (nearest descriptor), "
                "%.1f %% with some candidate within 10 cm, median error %.1f cm\n",
                lines ? "line " : "point", chosen, quality[lines][0], any, 100.0 * median(errors));
    quality_json[lines ? "lines" : "points"] = {{"samples", quality[lines][0]},
                                                {"chosen_within_10cm", chosen / 100.0},
                                                {"any_within_10cm", any / 100.0},
                                                {"median_chosen_error_cm", 100.0 * median(errors)}};
  }

  if (!output.empty()) {
    EvaluationOutputOptions out;
    out.integer_stamps = data.integerStamps();
    out.title = std::filesystem::path(dataset_path).filename().string() + " (" + forests + ")";
    nlohmann::json extra;
    extra["model"] = model_path;
    extra["dataset"] = dataset_path;
    extra["frame_selection"] = source_options.frames;
    if (!source_options.bag.empty()) {
      extra["format"] = data.formatDescription();
      extra["frames_used"] = data.usedIds();
      extra["min_motion"] = source_options.min_motion;
    }
    extra["forests"] = forests;
    extra["threads"] = thread_count;
    extra["software_version"] = kSoftwareVersion;
    if (!quality_json.is_null()) extra["prediction_quality"] = quality_json;
    extra["params"] = nlohmann::json::parse(relocalizerParamsToJson(params));
    out.extra_json = extra.dump();
    if (const Status written = writeEvaluationOutputs(output, records, summary, out); !written)
      return cli::fail(app, written.error(), 1);
    std::printf("wrote poses.txt, errors.csv, summary.json, trajectory.png, errors.png to %s\n",
                output.c_str());
  }
  return 0;
}
