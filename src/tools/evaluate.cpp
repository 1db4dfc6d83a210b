// evaluate: relocalizes every selected frame of a dataset (a folder or a rosbag)
// with a trained model and reports accuracy and latency as the relocalization
// literature does. With --learn-frames the model is first learned online from
// other frames of the dataset, as the node learns beside SLAM.

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_support.h"
#include "frame_source.h"
#include "relocalizer/core/progress.h"
#include "relocalizer/core/statistics.h"
#include "relocalizer/core/version.h"
#include "relocalizer/eval/evaluation.h"
#include "relocalizer/eval/plot.h"
#include "relocalizer/forest/training_config.h"
#include "relocalizer/online/key_frame_feed.h"
#include "relocalizer/pose/relocalizer.h"

using namespace relocalizer;

int main(int argc, char** argv) {
  CLI::App app{
      "Relocalizes each selected frame of a dataset independently and prints the share within "
      "5 cm / 5 deg and 2 cm / 2 deg, median errors, ATE RMSE, frames without a pose and latency "
      "per stage. With --output it writes poses.txt (TUM format), errors.csv, summary.json, "
      "trajectory.png and errors.png. The frames and their ground truth come from a dataset folder "
      "(--dataset) or a rosbag (--bag) with the same pose source as train --bag. With "
      "--learn-frames the model is learned online first (key frames, background retraining as in "
      "the node's learn mode), from nothing or continuing --model, and a learning curve is added.",
      "evaluate"};
  std::string model_path, output, config, forests = "both";
  int threads = 0;
  bool prediction_quality = false;
  app.add_option("-m,--model", model_path,
                 "Model file written by train (required without --learn-frames); with "
                 "--learn-frames a saved online model to continue (needs MODEL.keyframes)");
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
  std::string learn_frames, learn_min_motion = formatMinMotion(KeyFrameMotion{}), learn_config,
      save_model;
  int curve_every = 50;
  LearningParams learning;
  const std::string group = "Online learning (--learn-frames)";
  auto* learn_option =
      app.add_option("--learn-frames", learn_frames,
                     "Learn online from these frames of the --dataset folder, in order, using "
                     "their ground truth as the SLAM pose; then relocalize --frames")
          ->group(group);
  const auto learn_only = [&](CLI::Option* option) { option->needs(learn_option)->group(group); };
  learn_only(app.add_option("--learn-min-motion", learn_min_motion,
                            "Key frames: METRES,DEGREES of motion since the last key frame "
                            "(the node's learn_min_motion)")
                 ->capture_default_str());
  learn_only(app.add_option("--learn-config", learn_config,
                            "Training YAML (as train --config) for the retrains"));
  learn_only(app.add_option("--max-keyframes", learning.max_keyframes,
                            "Cap on stored key frames (the node's learn_max_keyframes)")
                 ->check(CLI::Range(2, 100000))
                 ->capture_default_str());
  learn_only(app.add_option("--curve-every", curve_every,
                            "Learn frames between learning-curve points (each retrains and "
                            "relocalizes every --frames frame)")
                 ->check(CLI::Range(1, 1000000))
                 ->capture_default_str());
  learn_only(app.add_flag("--learn-surface-gate", learning.surface_gate,
                          "Refuse poses off the learned surface (the node's learn_surface_gate)"));
  learn_only(app.add_option("--save-model", save_model,
                            "Write the learned model and its key frames (MODEL.keyframes) here"));
  if (const int code = cli::parse(app, argc, argv); code >= 0) return code;
  if (model_path.empty() && learn_frames.empty())
    return cli::fail(app, "--model is required (or --learn-frames to learn the model online)");
  if (!learn_frames.empty() && !source_options.bag.empty())
    return cli::fail(app, "--learn-frames learns from a --dataset folder, not from --bag");

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
  std::printf("%s\n", data.summary().c_str());
  const int thread_count = cli::resolveThreads(threads);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, thread_count);

  // Prediction quality per forest, summed over frames: samples, chosen within 10 cm, any within.
  long quality[2][3] = {{0, 0, 0}, {0, 0, 0}};
  std::vector<float> chosen_errors[2];
  int skipped = 0;
  // Every selected frame through one model; `measure` adds the prediction quality.
  const auto evaluateAll = [&](const Relocalizer& relocalizer, bool measure,
                               const std::string& label) -> Expected<std::vector<EvaluationRecord>> {
    std::vector<EvaluationRecord> records;
    const Model& model = relocalizer.model();
    skipped = 0;
    ProgressBar bar(label, data.size());
    for (size_t i = 0; i < data.size(); ++i) {
      bar.advance();
      if (!data.groundTruth(i)) {
        ++skipped;
        continue;
      }
      auto frame = data.load(i);
      if (!frame) return makeError(frame.error());
      const Relocalization result = relocalizer.relocalize(*frame);
      for (int lines = 0; measure && lines < 2; ++lines) {
        if ((lines ? model.lines : model.points).empty()) continue;
        auto q = relocalizer.measurePredictions(*frame, lines == 1);
        if (!q) return makeError(q.error());
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
    return records;
  };

  std::shared_ptr<const Relocalizer> relocalizer;
  std::vector<EvaluationRecord> records;
  nlohmann::json learning_json;
  if (learn_frames.empty()) {
    auto loaded = Relocalizer::fromFile(model_path, params);
    if (!loaded) return cli::fail(app, loaded.error());
    relocalizer = std::move(*loaded);
  } else {
    auto checked = readLearningParams(learning, learn_min_motion, learn_config);
    if (!checked) return cli::fail(app, "learning: " + checked.error());
    learning = *checked;
    auto learn_data = cli::DatasetArguments{source_options.dataset, source_options.format,
                                            learn_frames, source_options.split}
                          .open();
    if (!learn_data) return cli::fail(app, learn_data.error());
    const Dataset& learn = **learn_data;
    std::printf("learning from %zu frames (%s), key frames at %s m,deg, at most %d stored\n",
                learn.size(), learn_frames.c_str(), learn_min_motion.c_str(), learning.max_keyframes);
    KeyFrameFeed feed(learning, params, OnlineLearner::Mode::Inline);
    OnlineLearner& learner = feed.learner();
    if (!model_path.empty())
      if (Status resumed = learner.resume(model_path); !resumed) return cli::fail(app, resumed.error());
    nlohmann::json curve = nlohmann::json::array();
    Plot plot;
    plot.title = "learning curve: " + std::filesystem::path(dataset_path).filename().string();
    plot.x_label = "frames learned";
    plot.y_label = "% within 5 cm / 5 deg";
    plot.y_min = 0.0;
    plot.y_max = 100.0;
    PlotSeries series = PlotSeries::styled("online model", plotColour(0), true, 1);
    double compress_seconds = 0.0, retrain_seconds = 0.0;
    int without_pose = 0, learned = 0;
    for (size_t i = 0; i < learn.size(); ++i) {
      // A frame without a pose is SLAM having lost track: never learned from.
      const KeyFrameFeed::Result fed = feed.offer(learn.groundTruth(i), [&] { return learn.load(i); });
      if (!fed.why.empty()) return cli::fail(app, fed.why);
      if (fed.outcome == KeyFrameFeed::Result::Outcome::Untracked) ++without_pose;
      compress_seconds += fed.store_seconds;
      ++learned;
      if (learned % curve_every != 0 && i + 1 != learn.size()) continue;
      const auto start = std::chrono::steady_clock::now();
      if (Status drained = learner.drain(); !drained) return cli::fail(app, drained.error());
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const LearningStatus status = learner.status();
      retrain_seconds = status.last_retrain_seconds;
      relocalizer = learner.current();
      double accuracy = 0.0;
      if (relocalizer) {
        auto evaluated = evaluateAll(*relocalizer, false, "curve " + std::to_string(learned));
        if (!evaluated) return cli::fail(app, evaluated.error());
        records = std::move(*evaluated);
        accuracy = summarizeEvaluation(records).accuracy.within_5cm_5deg;
      }
      std::printf("after %4d frames: %3d key frames (%d stored), retrain %.1f s, %.1f %% within 5 cm / 5 deg\n",
                  learned, status.keyframes_added, status.keyframes_stored, seconds, 100.0 * accuracy);
      curve.push_back({{"frames_learned", learned},
                       {"keyframes", status.keyframes_added},
                       {"keyframes_stored", status.keyframes_stored},
                       {"retrain_seconds", seconds},
                       {"within_5cm_5deg", accuracy}});
      series.x.push_back(learned);
      series.y.push_back(100.0 * accuracy);
    }
    const LearningStatus status = learner.status();
    if (!relocalizer)
      return cli::fail(app, "learned no model: only " + std::to_string(status.keyframes_added) +
                                " key frames in --learn-frames " + learn_frames);
    if (without_pose) std::printf("%d learn frames without ground truth were not learned from\n", without_pose);
    const double per_keyframe_retrain = retrain_seconds / std::max(1, status.keyframes_learned);
    const double per_keyframe_compress = compress_seconds / std::max(1, status.keyframes_added);
    std::printf("update time per key frame: %.1f ms to store (caller's thread), %.2f s of retraining "
                "(%d threads; the last retrain took %.1f s for %d key frames); model %.1f MB, key frames %.1f MB\n",
                1000.0 * per_keyframe_compress, per_keyframe_retrain, thread_count, retrain_seconds,
                status.keyframes_learned, status.model_bytes / 1e6, status.store_bytes / 1e6);
    if (!save_model.empty()) {
      if (Status saved = learner.save(save_model); !saved) return cli::fail(app, saved.error(), 1);
      std::printf("wrote %s and %s\n", save_model.c_str(), keyFramesPath(save_model).c_str());
    }
    plot.series.push_back(series);
    learning_json = {{"learn_frames", learn_frames},
                     {"learn_min_motion", learn_min_motion},
                     {"max_keyframes", learning.max_keyframes},
                     {"surface_gate", learning.surface_gate},
                     {"keyframes_added", status.keyframes_added},
                     {"keyframes_stored", status.keyframes_stored},
                     {"keyframes_evicted", status.keyframes_evicted},
                     {"store_seconds_per_keyframe", per_keyframe_compress},
                     {"retrain_seconds_per_keyframe", per_keyframe_retrain},
                     {"last_retrain_seconds", retrain_seconds},
                     {"model_bytes", status.model_bytes},
                     {"store_bytes", status.store_bytes},
                     {"curve", curve}};
    if (!output.empty()) {
      std::filesystem::create_directories(output);
      if (!plot.save(output + "/learning_curve.png"))
        return cli::fail(app, output + "/learning_curve.png: cannot write", 1);
    }
  }
  const Model& model = relocalizer->model();
  std::printf("model %s: %zu point trees, %zu line trees, trained on %d images of %s\n",
              model_path.empty() ? "(learned online)" : model_path.c_str(), model.points.trees.size(),
              model.lines.trees.size(), model.summary.images, model.summary.dataset.c_str());
  if (const std::string limits = relocalizer->limitations(); !limits.empty())
    std::printf("warning: %s\n", limits.c_str());
  if (learn_frames.empty() || prediction_quality) {
    auto evaluated = evaluateAll(*relocalizer, prediction_quality, "evaluating");
    if (!evaluated) return cli::fail(app, evaluated.error());
    records = std::move(*evaluated);
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
    if (!learning_json.is_null()) extra["learning"] = learning_json;
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
    std::printf("wrote poses.txt, errors.csv, summary.json, trajectory.png, errors.png%s to %s\n",
                learn_frames.empty() ? "" : ", learning_curve.png", output.c_str());
  }
  return 0;
}
