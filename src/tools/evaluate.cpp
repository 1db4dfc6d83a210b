// evaluate: relocalizes every selected frame of a dataset (a folder or a rosbag)
// with a trained model and reports accuracy and latency as the relocalization
// literature does. With --learn-frames the model is first learned online from
// other frames of the dataset, as the node learns beside SLAM.

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "cli_support.h"
#include "evaluate_options.h"
#include "learning_curve.h"
#include "named_places.h"
#include "relocalizer/core/version.h"
#include "relocalizer/data/changed_frame_source.h"
#include "relocalizer/eval/frame_evaluation.h"
#include "relocalizer/eval/latency_benchmark.h"
#include "relocalizer/eval/plot.h"
#include "relocalizer/forest/training_config.h"
#include "relocalizer/online/key_frame_feed.h"
#include "relocalizer/online/place_files.h"
#include "relocalizer/online/submap_learner.h"
#include "relocalizer/relocalize/place_set.h"
#include "relocalizer/relocalize/relocalizer.h"
#include "source_arguments.h"
#include "submap_places.h"

using namespace relocalizer;
using relocalizer::cli::Learned;
using relocalizer::cli::LearnOptions;
using relocalizer::cli::Options;

namespace {

// What the learn frames came to in the feed.
struct FeedCounts {
  int offered = 0, untracked = 0, stored = 0, covered = 0;
  double store_seconds = 0.0;  // storing key frames, on this thread
};

// --learn-frames' parameters checked into `l.learning` and its frames opened;
// the first line says `what` is learned, capped at `cap`.
Expected<std::unique_ptr<Dataset>> openLearning(const Options& o, LearnOptions& l, const char* what,
                                                const char* cap) {
  auto checked = readLearningParams(l.learning, l.learn_min_motion, l.learn_config);
  if (!checked) return makeError("learning: " + checked.error());
  l.learning = *checked;
  auto learn =
      cli::DatasetArguments{o.source.path, o.source.format, l.learn_frames, o.source.split}.open();
  if (!learn) return makeError(learn.error());
  std::printf("%s from %zu frames (%s), key frames at %s m,deg, at most %d %s\n", what,
              (*learn)->size(), l.learn_frames.c_str(), l.learn_min_motion.c_str(),
              l.learning.max_keyframes, cap);
  return std::move(*learn);
}

// The learning loop of --learn-frames, whichever learner the feed holds: every learn frame
// offered in order, its ground truth as SLAM's pose (a frame without one is SLAM having lost
// track: never learned from), and `point` drawn every `curve_every` frames and after the last.
// A refused key frame is printed, and SLAM's map moving; any other failure is returned.
Status learnFrames(KeyFrameFeed& feed, const Dataset& learn, int curve_every, FeedCounts& counts,
                   const std::function<Status()>& point) {
  using Outcome = KeyFrameFeed::Result::Outcome;
  for (size_t i = 0; i < learn.size(); ++i) {
    const KeyFrameFeed::Result fed =
        feed.offer(learn.groundTruth(i), [&] { return learn.load(i); });
    if (fed.outcome == Outcome::Refused)
      std::printf("not learned: %s\n", fed.why.c_str());
    else if (!fed.why.empty())
      return makeError(fed.why);
    if (!fed.map_moved.empty()) std::printf("%s\n", fed.map_moved.c_str());
    counts.untracked += fed.outcome == Outcome::Untracked;
    counts.stored += fed.outcome == Outcome::Learned;
    counts.covered += fed.outcome == Outcome::Covered;
    counts.store_seconds += fed.store_seconds;
    if (++counts.offered % curve_every != 0 && i + 1 != learn.size()) continue;
    if (Status drawn = point(); !drawn) return drawn;
  }
  return okStatus();
}

// One store's curve point: the retrain, then `data` relocalized on the model
// (into `out`).
Status onlinePoint(const Options& o, OnlineLearner& learner, const FrameSource& data, int learned,
                   cli::LearningCurve& curve, Learned& out) {
  // Inline: the retrain runs inside drain(), on this thread and TBB's, so
  // the process's CPU time over it is the retrain's.
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = processCpuSeconds();
  if (Status drained = learner.drain(); !drained) return drained;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cpu_seconds = processCpuSeconds() - cpu_start;
  const LearningStatus status = learner.status();
  out.relocalizer = learner.current();
  double accuracy = 0.0;
  if (out.relocalizer) {
    auto evaluated = evaluateFrames(*out.relocalizer, data, false,
                                    "curve " + std::to_string(learned), o.hints("").get());
    if (!evaluated) return makeError(evaluated.error());
    out.evaluation = std::move(*evaluated);
    accuracy = summarizeEvaluation(out.evaluation.records).accuracy.within_5cm_5deg;
  }
  std::printf(
      "after %4d frames: %3d key frames (%d stored), retrain %.2f s (%.2f CPU-s), %.1f %% "
      "within 5 cm / 5 deg\n",
      learned, status.keyframes_added, status.keyframes_stored, seconds, cpu_seconds,
      100.0 * accuracy);
  if (status.last_retrain_seconds > 0.0) {
    const RetrainStages& t = status.last_retrain_stages;
    std::printf(
        "  last retrain %.2f s: decode %.2f, surface %.2f, sampling %.2f, growing %.2f, "
        "serving %.2f\n",
        status.last_retrain_seconds, t.decode, t.surface, t.sampling, t.growing, t.serving);
  }
  curve.add(learned, accuracy,
            {{"keyframes", status.keyframes_added},
             {"keyframes_stored", status.keyframes_stored},
             {"retrain_seconds", seconds},
             {"retrain_cpu_seconds", cpu_seconds}});
  return okStatus();
}

// --learn-frames: learns the model online from the learn frames, evaluating
// `data` at every curve point. Exits when learning or saving failed.
cli::Exit learnOnline(const cli::App& app, const Options& o, LearnOptions l,
                      const RelocalizerParams& params, const FrameSource& data, int thread_count,
                      Learned& out) {
  auto learn = openLearning(o, l, "learning", "stored");
  if (!learn) return cli::fail(app, learn.error());
  const LearningParams& learning = l.learning;
  OnlineLearner learner(learning, params, OnlineLearner::Mode::Inline);
  if (!o.model_path.empty())
    if (Status resumed = learner.resume(o.model_path); !resumed)
      return cli::fail(app, resumed.error());
  KeyFrameFeed feed(learner, learning);
  cli::LearningCurve curve(data.path());
  FeedCounts counts;
  const auto point = [&] { return onlinePoint(o, learner, data, counts.offered, curve, out); };
  if (Status learned = learnFrames(feed, **learn, l.curve_every, counts, point); !learned)
    return cli::fail(app, learned.error());
  // Inline: nothing retrains after the last curve point.
  const LearningStatus status = learner.status();
  const double retrain_seconds = status.last_retrain_seconds;
  if (!out.relocalizer)
    return cli::fail(app, "learned no model: only " + std::to_string(status.keyframes_added) +
                              " key frames in --learn-frames " + l.learn_frames);
  if (counts.untracked)
    std::printf("%d learn frames without ground truth were not learned from\n", counts.untracked);
  const double per_keyframe_retrain = retrain_seconds / std::max(1, status.keyframes_learned);
  const double per_keyframe_compress = counts.store_seconds / std::max(1, status.keyframes_added);
  std::printf(
      "update time per key frame: %.1f ms to store (caller's thread), %.2f s of retraining "
      "(%d threads; the last retrain took %.1f s for %d key frames); model %.1f MB, key frames "
      "%.1f MB\n",
      1000.0 * per_keyframe_compress, per_keyframe_retrain, thread_count, retrain_seconds,
      status.keyframes_learned, status.model_bytes / 1e6, status.store_bytes / 1e6);
  if (!l.save_model.empty()) {
    if (Status saved = learner.save(l.save_model); !saved) return cli::fail(app, saved.error(), 1);
    std::printf("wrote %s and %s\n", l.save_model.c_str(), keyFramesPath(l.save_model).c_str());
  }
  out.json = {{"learn_frames", l.learn_frames},
              {"learn_min_motion", l.learn_min_motion},
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
              {"curve", curve.json()}};
  if (Status saved = curve.save(o.output); !saved) return cli::fail(app, saved.error(), 1);
  return std::nullopt;
}

// Submaps' curve point: every submap trained, then `data` relocalized across
// them as places of one group (into `out`).
Status submapPoint(const Options& o, SubmapLearner& submaps, const FrameSource& data,
                   const FeedCounts& counts, cli::LearningCurve& curve, Learned& out) {
  if (Status drained = submaps.drain(); !drained) return drained;
  PlaceSet places;
  if (Status put = putLearned(submaps.places(), places); !put) return put;
  auto evaluated = evaluateFrames(places, data, "curve " + std::to_string(counts.offered),
                                  o.hints(submaps.names().map_frame).get());
  if (!evaluated) return makeError(evaluated.error());
  out.evaluation = std::move(*evaluated);
  const double accuracy = summarizeEvaluation(out.evaluation.records).accuracy.within_5cm_5deg;
  std::printf(
      "after %4d frames: %3d key frames in %d submaps (%d covered), %.1f %% within 5 cm "
      "/ 5 deg\n",
      counts.offered, counts.stored, submaps.index().submapCount(), counts.covered,
      100.0 * accuracy);
  curve.add(counts.offered, accuracy,
            {{"keyframes", counts.stored},
             {"submaps", submaps.index().submapCount()},
             {"keyframes_covered", counts.covered}});
  return okStatus();
}

// --learn-frames --submaps: the learn frames cut into submaps of --max-keyframes
// each (online/submap_learner.h), and `data` relocalized across all of them as
// places in one map frame at every curve point (the last point's evaluation in
// `out`). Exits when learning or saving failed.
cli::Exit learnSubmaps(const cli::App& app, const Options& o, LearnOptions l,
                       const RelocalizerParams& params, const FrameSource& data, Learned& out) {
  auto learn = openLearning(o, l, "learning submaps", "each");
  if (!learn) return cli::fail(app, learn.error());
  SubmapLearner submaps(l.learning, l.submap_rule, params);
  if (!o.model_path.empty()) {
    auto resumed = submaps.resume(o.model_path);
    if (!resumed) return cli::fail(app, resumed.error());
    for (const std::string& warning : *resumed) std::printf("warning: %s\n", warning.c_str());
    std::printf("continuing %d submaps of %s\n", submaps.index().submapCount(),
                o.model_path.c_str());
  }
  // Frozen submaps go to disk as they freeze and leave memory.
  if (!l.save_model.empty())
    if (Status used = submaps.useFolder(l.save_model); !used)
      return cli::fail(app, used.error(), 1);
  KeyFrameFeed feed(submaps, l.learning);
  cli::LearningCurve curve(data.path());
  FeedCounts counts;
  const auto point = [&] { return submapPoint(o, submaps, data, counts, curve, out); };
  if (Status learned = learnFrames(feed, **learn, l.curve_every, counts, point); !learned)
    return cli::fail(app, learned.error());
  if (submaps.models().empty())
    return cli::fail(app, "learned no model: only " + std::to_string(counts.stored) +
                              " key frames in --learn-frames " + l.learn_frames);
  std::vector<int> per_submap;
  for (int s = 0; s < submaps.index().submapCount(); ++s)
    per_submap.push_back(static_cast<int>(submaps.index().keyFrames(s).size()));
  std::printf("%d submaps, key frames per submap (seeds included): %s\n",
              submaps.index().submapCount(), nlohmann::json(per_submap).dump().c_str());
  if (!l.save_model.empty()) {
    const auto start = std::chrono::steady_clock::now();
    if (Status saved = submaps.save(l.save_model); !saved) return cli::fail(app, saved.error(), 1);
    std::printf("wrote %s (the active submap and the manifest in %.2f s)\n",
                submapManifestPath(l.save_model).c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  out.json = {{"learn_frames", l.learn_frames},
              {"learn_min_motion", l.learn_min_motion},
              {"max_keyframes", l.learning.max_keyframes},
              {"submaps", per_submap.size()},
              {"submap_keyframes", per_submap},
              {"keyframes_stored", counts.stored},
              {"keyframes_covered", counts.covered},
              {"curve", curve.json()}};
  if (Status saved = curve.save(o.output); !saved) return cli::fail(app, saved.error(), 1);
  return std::nullopt;
}

// Options that do not go together, or empty.
std::string combinationError(const Options& o, const LearnOptions& learn, bool many_places) {
  if (many_places && !learn.learn_frames.empty())
    return "--learn-frames learns one place: give one --model PATH";
  if (std::string error = cli::relearnAgreementError(learn.submap_rule, learn.submaps);
      !error.empty())
    return error;
  if (many_places && o.prediction_quality)
    return "--prediction-quality measures one model's forests: give one --model";
  if (!o.expect_place.empty() && !many_places)
    return "--expect-place needs places: --model NAME=PATH (repeated)";
  if (o.models.empty() && learn.learn_frames.empty())
    return "--model is required (or --learn-frames to learn the model online)";
  if (!learn.learn_frames.empty() && !o.source.bag.empty())
    return "--learn-frames learns from a --dataset folder, not from --bag";
  // Frozen submaps are written into the working folder as they freeze: a
  // continued folder is only changed when asked to.
  if (learn.submaps && !o.model_path.empty() && learn.save_model.empty())
    return "continuing " + o.model_path +
           " with --submaps needs --save-model (the same folder updates it in place)";
  if (!learn.submaps && !learn.learn_frames.empty() && placeIsFolder(o.model_path))
    return "--model " + o.model_path +
           " is a folder of learned submaps: continue it with --submaps";
  if (o.prediction_quality && placeIsFolder(o.model_path))
    return "--prediction-quality measures one model's forests, not a folder of submaps";
  if (learn.submaps && o.prediction_quality)
    return "--prediction-quality measures one model's forests, not --submaps";
  if (auto hint = parseHintNoise(o.hint); !o.hint.empty() && !hint) return hint.error();
  if (many_places && !o.hint.empty() && o.expect_place.empty())
    return "--hint with many places needs --expect-place (the map frame the hint is in)";
  return {};
}

// --config's relocalizer parameters (defaults without one), with the --forests used.
Expected<RelocalizerParams> relocalizerParams(const Options& o) {
  RelocalizerParams params;
  if (!o.config.empty()) {
    auto loaded = loadRelocalizerParams(o.config);
    if (!loaded) return makeError(loaded.error());
    params = *loaded;
  }
  params.use_points = o.forests != "lines";
  params.use_lines = o.forests != "points";
  return params;
}

// The frames to relocalize, seen under --light-* when given.
Expected<std::unique_ptr<FrameSource>> openFrames(const Options& o) {
  if (const std::string invalid = o.change.validationError(); !invalid.empty())
    return makeError("--light-" + invalid);
  auto source = o.source.open();
  if (!source || o.change.identity()) return source;
  return std::unique_ptr<FrameSource>(
      std::make_unique<ChangedFrameSource>(std::move(*source), o.change));
}

// What summary.json adds to the evaluation's own figures.
std::string summaryFields(const Options& o, const FrameSource& data, const nlohmann::json& learning,
                          const std::string& prediction_json, int thread_count,
                          const RelocalizerParams& params) {
  nlohmann::json extra;
  if (o.model_path.empty() && !o.models.empty())
    extra["places"] = o.models;
  else
    extra["model"] = o.model_path;
  if (!learning.is_null()) extra["learning"] = learning;
  extra["dataset"] = data.path();
  extra["frame_selection"] = o.source.frames;
  if (!o.source.bag.empty()) {
    extra["format"] = data.formatDescription();
    extra["frames_used"] = data.usedIds();
    extra["min_motion"] = o.source.min_motion;
  }
  extra["forests"] = o.forests;
  if (!o.hint.empty()) extra["hint"] = o.hint;
  if (!o.change.identity())
    extra["light_change"] = {{"stops", o.change.stops},
                             {"kelvin", o.change.kelvin},
                             {"gamma", o.change.gamma},
                             {"description", o.change.describe()}};
  extra["threads"] = thread_count;
  extra["software_version"] = kSoftwareVersion;
  const nlohmann::json quality = nlohmann::json::parse(prediction_json);
  if (!quality.is_null()) extra["prediction_quality"] = quality;
  extra["params"] = nlohmann::json::parse(relocalizerParamsToJson(params));
  return extra.dump();
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Relocalizes each selected frame of a dataset independently and prints the share within "
      "5 cm / 5 deg and 2 cm / 2 deg, median errors, ATE RMSE, frames without a pose and latency "
      "per stage. With --output it writes poses.txt (TUM format), errors.csv, summary.json, "
      "trajectory.png and errors.png. The frames and their ground truth come from a dataset folder "
      "(--dataset) or a rosbag (--bag) with the same pose source as train --bag. With "
      "--learn-frames the model is learned online first (key frames, background retraining as in "
      "the node's learn mode), from nothing or continuing --model, and a learning curve is added.",
      "evaluate"};
  Options o;
  LearnOptions learn;
  addOptions(app, o, learn);
  if (const cli::Exit done = app.parse(argc, argv)) return *done;
  const bool many_places =
      o.models.size() > 1 || (o.models.size() == 1 && o.models[0].find('=') != std::string::npos);
  if (!many_places && !o.models.empty()) o.model_path = o.models[0];
  if (const std::string error = combinationError(o, learn, many_places); !error.empty())
    return cli::fail(app, error);

  auto configured = relocalizerParams(o);
  if (!configured) return cli::fail(app, configured.error());
  const RelocalizerParams& params = *configured;

  auto source = openFrames(o);
  if (!source) return cli::fail(app, source.error());
  const FrameSource& data = **source;
  std::printf("%s\n", data.summary().c_str());
  if (!o.hint.empty())
    std::printf("every frame hinted: %s\n", formatHintNoise(*parseHintNoise(o.hint)).c_str());
  const int thread_count = cli::resolveThreads(o.threads);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, thread_count);

  Learned learned;
  FrameEvaluation evaluation;
  // Answers come from a set of places (places.csv names each frame's).
  const bool submap_folder = learn.learn_frames.empty() && placeIsFolder(o.model_path);
  const bool by_places = many_places || learn.submaps || submap_folder;
  if (submap_folder) {
    auto evaluated = cli::evaluateSubmapFolder(
        o.model_path, params, data, [&](const std::string& frame) { return o.hints(frame); });
    if (!evaluated) return cli::fail(app, evaluated.error());
    evaluation = std::move(*evaluated);
  } else if (learn.submaps) {
    if (const cli::Exit done = learnSubmaps(app, o, learn, params, data, learned)) return *done;
    evaluation = std::move(learned.evaluation);
  } else if (many_places) {
    auto evaluated = cli::evaluateNamedPlaces(o, params, data);
    if (!evaluated) return cli::fail(app, evaluated.error());
    evaluation = std::move(*evaluated);
  } else if (learn.learn_frames.empty()) {
    auto opened = openPlace("", o.model_path, "", params);
    if (!opened) return cli::fail(app, opened.error());
    learned.relocalizer = std::move(opened->places.front().relocalizer);
  } else if (const cli::Exit done =
                 learnOnline(app, o, learn, params, data, thread_count, learned)) {
    return *done;
  }
  if (!by_places) {
    const Relocalizer& relocalizer = *learned.relocalizer;
    const Model& model = relocalizer.model();
    std::printf("model %s: %zu point trees, %zu line trees, trained on %d images of %s\n",
                o.model_path.empty() ? "(learned online)" : o.model_path.c_str(),
                model.points.trees.size(), model.lines.trees.size(), model.summary.images,
                model.summary.dataset.c_str());
    if (const std::string limits = relocalizer.limitations(); !limits.empty())
      std::printf("warning: %s\n", limits.c_str());
    evaluation = std::move(learned.evaluation);
    if (learn.learn_frames.empty() || o.prediction_quality) {
      auto evaluated =
          evaluateFrames(relocalizer, data, o.prediction_quality, "evaluating", o.hints("").get());
      if (!evaluated) return cli::fail(app, evaluated.error());
      evaluation = std::move(*evaluated);
    }
  }
  const std::vector<EvaluationRecord>& records = evaluation.records;
  if (records.empty()) return cli::fail(app, data.path() + ": no selected frame has ground truth");
  if (evaluation.skipped)
    std::printf("skipped %d frames without ground truth\n", evaluation.skipped);

  const EvaluationSummary summary = summarizeEvaluation(records, o.expect_place);
  const std::string title = "evaluate: " + o.forests + " forests, " + std::to_string(thread_count) +
                            (thread_count == 1 ? " thread" : " threads");
  std::printf("\n%s", formatEvaluationTable(summary, title).c_str());
  const PredictionReport quality = reportPredictionQuality(evaluation);
  std::printf("%s", quality.text.c_str());
  if (o.output.empty()) return 0;

  EvaluationOutputOptions out;
  out.integer_stamps = data.integerStamps();
  out.title = std::filesystem::path(data.path()).filename().string() + " (" + o.forests + ")";
  out.extra_json = summaryFields(o, data, learned.json, quality.json, thread_count, params);
  out.places = by_places;
  if (const Status written = writeEvaluationOutputs(o.output, records, summary, out); !written)
    return cli::fail(app, written.error(), 1);
  std::printf("wrote poses.txt, %serrors.csv, summary.json, trajectory.png, errors.png%s to %s\n",
              by_places ? "places.csv, " : "",
              learn.learn_frames.empty() ? "" : ", learning_curve.png", o.output.c_str());
  return 0;
}
