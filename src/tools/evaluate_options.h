#pragma once
// evaluate's command line: what it evaluates (Options), how it learns first
// (LearnOptions, --learn-frames) and what learning leaves for the evaluation
// (Learned), and the options that fill them (addOptions).

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "learn_options.h"
#include "relocalizer/core/key_frame_rule.h"
#include "relocalizer/core/photometric_change.h"
#include "relocalizer/eval/frame_evaluation.h"
#include "relocalizer/eval/simulated_hints.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/online/submap_rule.h"
#include "relocalizer/relocalize/relocalizer.h"
#include "source_arguments.h"

namespace relocalizer::cli {

struct Options {
  std::vector<std::string> models;  // PATH, or NAME=PATH for each of many places
  std::string model_path;           // the one model without place names
  std::string expect_place;
  std::string output, config, forests = "both";
  int threads = 0;
  bool prediction_quality = false;
  cli::SourceOptions source;
  std::string hint;          // --hint: every frame relocalized with a hint near its ground truth
  PhotometricChange change;  // --light-stops, --light-kelvin, --light-gamma

  // One evaluation's hints in map frame `frame` (each draws the same), or none.
  std::unique_ptr<SimulatedHints> hints(const std::string& frame) const {
    if (hint.empty()) return nullptr;
    return std::make_unique<SimulatedHints>(*parseHintNoise(hint), frame);
  }
};

// --learn-frames and the options that go with it.
struct LearnOptions {
  std::string learn_frames, learn_min_motion = formatMinMotion(KeyFrameMotion{}), learn_config,
                            save_model;
  int curve_every = 50;
  bool submaps = false;
  LearningParams learning;
  SubmapParams submap_rule;
};

// What learning online leaves for the evaluation: the model, the evaluation
// of the last curve point, and the figures for summary.json.
struct Learned {
  std::shared_ptr<const Relocalizer> relocalizer;
  FrameEvaluation evaluation;
  nlohmann::json json;
};

// The world changed after training: --frames seen under other light.
inline void addChangeOptions(App& app, PhotometricChange& change) {
  const std::string group = "Changed light (--frames only; learn frames as recorded)";
  app.addOption("--light-stops", change.stops,
                "Light level or exposure in stops: linear light times 2^STOPS, clipped where "
                "the sensor saturates (-1: half the light)")
      ->range(-8.0, 8.0)
      ->group(group);
  app.addOption("--light-kelvin", change.kelvin,
                "Colour temperature of the light for a camera balanced for " +
                    std::to_string(static_cast<int>(PhotometricChange::kBalancedKelvin)) +
                    " K: 2700 a tungsten lamp, 6500 overcast daylight (0: unchanged)")
      ->range(0.0, PhotometricChange::kMaxKelvin)
      ->group(group);
  app.addOption("--light-gamma", change.gamma,
                "Another tone curve: each encoded value v in [0, 1] becomes v^GAMMA")
      ->range(0.2, 5.0)
      ->group(group);
}

inline void addOptions(App& app, Options& o, LearnOptions& l) {
  app.addOption("-m,--model", o.models,
                "Model file written by train (required without --learn-frames); with "
                "--learn-frames a saved online model to continue (needs MODEL.keyframes). "
                "A folder of learned submaps (--submaps --save-model) is evaluated as its set "
                "of places, or continued with --learn-frames --submaps; so is a model file "
                "made by train (no key frames: it is kept as it is, and only what its surface "
                "does not hold is learned, beside it). "
                "Many places: repeat it as NAME=PATH; every frame is then relocalized against "
                "the whole set, and places.csv names each frame's answering place");
  app.addOption("--expect-place", o.expect_place,
                "Many places: the place the frames were taken in; answers from any other "
                "place are counted as wrong-place answers");
  o.source.add(app, "Dataset folder with ground truth",
               "Frame ids to evaluate, e.g. 100-199,300-399 (default: all); for a bag, ids "
               "are indices in its synchronized frame order");
  app.addOption("-o,--output", o.output, "Folder for poses.txt, errors.csv, summary.json, plots");
  app.addOption(
      "-c,--config", o.config,
      "YAML file whose 'relocalizer:' section overrides the defaults (config/default.yaml)");
  app.addOption("--forests", o.forests, "points | lines | both")
      ->oneOf({"points", "lines", "both"})
      ->showDefault();
  app.addOption("-j,--threads", o.threads, "Worker threads inside each call (0 = every core)")
      ->range(0, 1024)
      ->showDefault();
  app.addFlag("--prediction-quality", o.prediction_quality,
              "Also report the share of forest predictions within 10 cm of the truth");
  app.addOption("--hint", o.hint,
                "ERROR_M,ERROR_DEG,SIGMA_M,SIGMA_DEG: each frame hinted (pose_hint.h) this far "
                "off its ground truth in random directions (seeded), declaring these sigmas; "
                "many places need --expect-place (the hint's map frame)");
  addChangeOptions(app, o.change);
  const std::string group = "Online learning (--learn-frames)";
  auto* learn_option =
      app.addOption("--learn-frames", l.learn_frames,
                    "Learn online from these frames of the --dataset folder, in order, using "
                    "their ground truth as the SLAM pose; then relocalize --frames")
          ->group(group);
  const auto learn_only = [&](Option* option) { option->needs(learn_option)->group(group); };
  learn_only(app.addOption("--learn-min-motion", l.learn_min_motion,
                           "Key frames: METRES,DEGREES of motion since the last key frame "
                           "(the node's learn_min_motion)")
                 ->showDefault());
  learn_only(app.addOption("--learn-config", l.learn_config,
                           "Training YAML (as train --config) for the retrains"));
  learn_only(app.addOption("--max-keyframes", l.learning.max_keyframes,
                           "Cap on stored key frames (the node's learn_max_keyframes)")
                 ->range(2, 100000)
                 ->showDefault());
  learn_only(app.addOption("--curve-every", l.curve_every,
                           "Learn frames between learning-curve points (each retrains and "
                           "relocalizes every --frames frame)")
                 ->range(1, 1000000)
                 ->showDefault());
  learn_only(app.addFlag("--learn-surface-gate", l.learning.surface_gate,
                         "Refuse poses off the learned surface (the node's learn_surface_gate)"));
  learn_only(app.addFlag("--submaps", l.submaps,
                         "Learn submaps (--max-keyframes each; a full one is frozen and a new "
                         "one starts) and relocalize across them as places in one map frame"));
  learn_only(addRelearnAgreement(app, l.submap_rule));
  learn_only(app.addOption("--save-model", l.save_model,
                           "Write the learned model and its key frames (MODEL.keyframes) here; "
                           "with --submaps a folder (manifest.json and each submap's pair), "
                           "which frozen submaps are written into as they freeze"));
}

}  // namespace relocalizer::cli
