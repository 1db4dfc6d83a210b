// threshold_curves: how the "no pose" threshold trades correct answers for
// false relocalizations. Relocalizes in-scene frames (with ground truth) and
// out-of-scene frames (another room the model never saw) with the evidence
// thresholds disabled, then sweeps each threshold (the inlier share, and the
// surface agreement of models with a scene surface) and draws, per threshold:
// the share of in-scene frames answered with a correct pose, with a wrong pose,
// and the share of out-of-scene frames answered at all.

#include <nlohmann/json.hpp>

#include "cli_support.h"
#include "relocalizer/eval/threshold_curves.h"
#include "source_arguments.h"

using namespace relocalizer;

int main(int argc, char** argv) {
  cli::App app{
      "Draws the trade-off behind the relocalizer's 'no pose' thresholds (solver.min_inlier_ratio "
      "and, for models with a scene surface, surface.min_agreement): for each threshold, the share "
      "of in-scene frames answered correctly (within 5 cm / 5 deg), answered wrongly, and the "
      "share "
      "of out-of-scene frames answered at all (false relocalizations). Writes curves.csv/png, "
      "agreement_curves.csv/png and curves.json. Each scene is a dataset folder or a rosbag.",
      "threshold_curves"};
  std::string model_path, in_scene, in_bag, in_frames, config, output;
  std::vector<std::string> out_of_scene, out_of_scene_bags;
  int threads = 0;
  cli::SourceOptions bags;  // topic and pose options shared by every bag
  app.addOption("-m,--model", model_path, "Model file")->required();
  auto* in_folder =
      app.addOption("--in-scene", in_scene, "Dataset of the model's scene, with ground truth");
  auto* in_bag_option =
      app.addOption("--bag", in_bag, "Rosbag of the model's scene, instead of --in-scene");
  in_folder->excludes(in_bag_option);
  app.addOption("--in-frames", in_frames,
                "Frame ids of the in-scene dataset or bag (default: all)");
  auto* out_folders =
      app.addOption("--out-of-scene", out_of_scene, "Datasets of other scenes (repeatable)");
  auto* out_bags = app.addOption("--out-of-scene-bag", out_of_scene_bags,
                                 "Rosbags of other scenes (repeatable; frames need poses too)");
  cli::SourceOptions::addBagOptions(app, nullptr, bags.bag_options, bags.min_motion);
  app.addOption("-c,--config", config, "YAML with a 'relocalizer:' section");
  app.addOption("-o,--output", output, "Folder for curves.csv, curves.png, curves.json")
      ->required();
  app.addOption("-j,--threads", threads, "Threads (0 = every core)")->range(0, 1024);
  if (const cli::Exit done = app.parse(argc, argv)) return *done;
  if (in_folder->count() + in_bag_option->count() == 0)
    return cli::fail(app, "one of --in-scene or --bag is required");
  if (out_folders->count() + out_bags->count() == 0)
    return cli::fail(app, "--out-of-scene or --out-of-scene-bag is required");

  RelocalizerParams params;
  if (!config.empty()) {
    auto loaded = loadRelocalizerParams(config);
    if (!loaded) return cli::fail(app, loaded.error());
    params = *loaded;
  }
  const GateSettings configured = gateSettings(params);
  auto relocalizer = Relocalizer::fromFile(model_path, withGatesOpen(params));
  if (!relocalizer) return cli::fail(app, relocalizer.error());
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            cli::resolveThreads(threads));

  // (folder, bag) of each scene, the in-scene one first.
  std::vector<std::pair<std::string, std::string>> scenes = {{in_scene, in_bag}};
  for (const std::string& path : out_of_scene) scenes.push_back({path, ""});
  for (const std::string& path : out_of_scene_bags) scenes.push_back({"", path});
  std::vector<GateAnswer> answers;
  for (size_t k = 0; k < scenes.size(); ++k) {
    bags.frames = k == 0 ? in_frames : "";
    auto source = bags.open(scenes[k].first, scenes[k].second);
    if (!source) return cli::fail(app, source.error());
    auto answered = answerFrames(**relocalizer, **source, k == 0);
    if (!answered) return cli::fail(app, answered.error());
    answers.insert(answers.end(), answered->begin(), answered->end());
  }
  std::vector<std::string> outside = out_of_scene;
  outside.insert(outside.end(), out_of_scene_bags.begin(), out_of_scene_bags.end());
  const nlohmann::json extra = {{"model", model_path},
                                {"in_scene", in_bag.empty() ? in_scene : in_bag},
                                {"out_of_scene", outside}};
  auto report = writeThresholdCurves(answers, configured, output, extra.dump());
  if (!report) return cli::fail(app, report.error(), 1);
  std::printf("%s", report->c_str());
  return 0;
}
