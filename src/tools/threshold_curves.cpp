// threshold_curves: how the "no pose" threshold trades correct answers for
// false relocalizations. Relocalizes in-scene frames (with ground truth) and
// out-of-scene frames (another room the model never saw) with the evidence
// thresholds disabled, then sweeps each threshold (the inlier share, and the
// surface agreement of models with a scene surface) and draws, per threshold:
// the share of in-scene frames answered with a correct pose, with a wrong pose,
// and the share of out-of-scene frames answered at all.

#include <tbb/global_control.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_support.h"
#include "relocalizer/core/progress.h"
#include "relocalizer/data/dataset.h"
#include "relocalizer/eval/metrics.h"
#include "relocalizer/eval/plot.h"
#include "relocalizer/pose/relocalizer.h"

using namespace relocalizer;

namespace {

struct Answer {
  bool in_scene = false;
  bool has_pose = false;  // the solver produced a pose at all
  bool correct = false;   // within 5 cm / 5 deg (in-scene only)
  int inliers = 0;
  float score = 0.0f;
  float agreement = -1.0f;  // share of the depth on the scene surface; < 0: not checked
};

Expected<std::vector<Answer>> relocalizeAll(const Relocalizer& relocalizer, const std::string& path,
                                            const std::string& frames, bool in_scene) {
  DatasetOptions options;
  options.frames = frames;
  auto dataset = openDataset(path, options);
  if (!dataset) return makeError(dataset.error());
  std::vector<Answer> answers;
  ProgressBar bar(in_scene ? "in-scene    " : "out-of-scene", (*dataset)->size());
  for (size_t i = 0; i < (*dataset)->size(); ++i) {
    bar.advance();
    auto frame = (*dataset)->load(i);
    if (!frame) return makeError(frame.error());
    const Relocalization r = relocalizer.relocalize(*frame);
    Answer a;
    a.in_scene = in_scene;
    a.has_pose = r.success;
    a.inliers = r.point_inliers + r.line_inliers;
    a.score = r.score;
    a.agreement = r.surface_agreement;
    if (in_scene && r.success && frame->ground_truth) {
      const FrameError e = frameError(frame->id, r.pose, *frame->ground_truth);
      a.correct = e.translation_m <= 0.05 && e.rotation_deg <= 5.0;
    }
    answers.push_back(a);
  }
  return answers;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Draws the trade-off behind the relocalizer's 'no pose' thresholds (solver.min_inlier_ratio "
      "and, for models with a scene surface, surface.min_agreement): for each threshold, the share "
      "of in-scene frames answered correctly (within 5 cm / 5 deg), answered wrongly, and the share "
      "of out-of-scene frames answered at all (false relocalizations). Writes curves.csv/png, "
      "agreement_curves.csv/png and curves.json.",
      "threshold_curves"};
  std::string model_path, in_scene, in_frames, config, output;
  std::vector<std::string> out_of_scene;
  int threads = 0;
  app.add_option("-m,--model", model_path, "Model file")->required();
  app.add_option("--in-scene", in_scene, "Dataset of the model's scene, with ground truth")->required();
  app.add_option("--in-frames", in_frames, "Frame ids of the in-scene dataset (default: all)");
  app.add_option("--out-of-scene", out_of_scene, "Datasets of other scenes (repeatable)")->required();
  app.add_option("-c,--config", config, "YAML with a 'relocalizer:' section");
  app.add_option("-o,--output", output, "Folder for curves.csv, curves.png, curves.json")->required();
  app.add_option("-j,--threads", threads, "Threads (0 = every core)")->check(CLI::Range(0, 1024));
  if (const int code = cli::parse(app, argc, argv); code >= 0) return code;

  RelocalizerParams params;
  if (!config.empty()) {
    auto loaded = loadRelocalizerParams(config);
    if (!loaded) return cli::fail(app, loaded.error());
    params = *loaded;
  }
  const int configured_min_inliers = params.solver.min_inliers;
  const float configured_ratio = params.solver.min_inlier_ratio;
  const float configured_agreement = params.surface.min_agreement;
  // Every pose the solver finds is kept; the sweeps apply the thresholds.
  params.solver.min_inliers = 0;
  params.solver.min_inlier_ratio = 0.0f;
  params.surface.min_agreement = 0.0f;
  auto relocalizer = Relocalizer::fromFile(model_path, params);
  if (!relocalizer) return cli::fail(app, relocalizer.error());
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, cli::resolveThreads(threads));

  std::vector<Answer> answers;
  auto inside = relocalizeAll(**relocalizer, in_scene, in_frames, true);
  if (!inside) return cli::fail(app, inside.error());
  answers = *inside;
  for (const std::string& path : out_of_scene) {
    auto outside = relocalizeAll(**relocalizer, path, "", false);
    if (!outside) return cli::fail(app, outside.error());
    answers.insert(answers.end(), outside->begin(), outside->end());
  }
  int in_total = 0, out_total = 0;
  for (const Answer& a : answers) (a.in_scene ? in_total : out_total)++;
  std::filesystem::create_directories(output);

  // One sweep per "no pose" gate, the other gates at their configured values:
  // the share of frames each threshold lets through.
  struct Sweep {
    std::string name, file, label;
    float configured;
    std::function<bool(const Answer&, float)> accepts;
    double chosen = -1;  // lowest threshold with at most 5 % out-of-scene answers
    nlohmann::json curve = nlohmann::json::array();
  };
  const bool surface_checked = std::any_of(answers.begin(), answers.end(),
                                           [](const Answer& a) { return a.agreement >= 0; });
  std::vector<Sweep> sweeps;
  sweeps.push_back({"min_inlier_ratio", "curves", "min_inlier_ratio (share of samples that are inliers)",
                    configured_ratio, [&](const Answer& a, float t) {
                      return a.score >= t && a.inliers >= configured_min_inliers &&
                             (a.agreement < 0 || a.agreement >= configured_agreement);
                    }});
  if (surface_checked)
    sweeps.push_back({"min_agreement", "agreement_curves",
                      "surface.min_agreement (share of the frame's depth on the scene surface)",
                      configured_agreement, [&](const Answer& a, float t) {
                        return a.score >= configured_ratio && a.inliers >= configured_min_inliers &&
                               a.agreement >= t;
                      }});
  nlohmann::json j;
  for (Sweep& sweep : sweeps) {
    std::ofstream csv(output + "/" + sweep.file + ".csv");
    csv << sweep.name << ",in_scene_correct,in_scene_wrong,out_of_scene_answered\n";
    auto correct = PlotSeries::styled("in-scene, correct pose", plotColour(2), true, 0);
    auto wrong = PlotSeries::styled("in-scene, wrong pose", plotColour(3), true, 0);
    auto outside_answered =
        PlotSeries::styled("other scenes, any pose (false relocalization)", plotColour(4), true, 0);
    const float top = sweep.name == "min_agreement" ? 1.0f : 0.6f;
    for (int step = 0; step <= 120; ++step) {
      const float threshold = top * step / 120.0f;
      int c = 0, w = 0, o = 0;
      for (const Answer& a : answers) {
        if (!a.has_pose || !sweep.accepts(a, threshold)) continue;
        if (!a.in_scene) ++o;
        else if (a.correct) ++c;
        else ++w;
      }
      const double cs = in_total ? 100.0 * c / in_total : 0, ws = in_total ? 100.0 * w / in_total : 0,
                   os = out_total ? 100.0 * o / out_total : 0;
      csv << threshold << "," << cs << "," << ws << "," << os << "\n";
      correct.x.push_back(threshold);
      correct.y.push_back(cs);
      wrong.x.push_back(threshold);
      wrong.y.push_back(ws);
      outside_answered.x.push_back(threshold);
      outside_answered.y.push_back(os);
      sweep.curve.push_back({{sweep.name, threshold}, {"correct", cs}, {"wrong", ws}, {"out_of_scene", os}});
      if (sweep.chosen < 0 && os <= 5.0) sweep.chosen = threshold;
    }
    Plot plot;
    plot.title = "'no pose' threshold: answers by " + sweep.name + " (the other gates as configured)";
    plot.x_label = sweep.label;
    plot.y_label = "share of frames (%)";
    plot.y_min = 0;
    plot.y_max = 100;
    plot.series = {correct, wrong, outside_answered};
    plot.vertical_lines = {sweep.configured};
    plot.horizontal_lines = {5.0};
    plot.save(output + "/" + sweep.file + ".png", 1000, 600);
    j[sweep.name] = {{"configured", sweep.configured},
                     {"lowest_with_at_most_5pct_false", sweep.chosen},
                     {"curve", sweep.curve}};
  }
  j["model"] = model_path;
  j["in_scene"] = in_scene;
  j["out_of_scene"] = out_of_scene;
  j["in_scene_frames"] = in_total;
  j["out_of_scene_frames"] = out_total;
  j["configured_min_inliers"] = configured_min_inliers;
  std::ofstream(output + "/curves.json") << j.dump(2) << "\n";
  std::printf("%d in-scene and %d out-of-scene frames%s\n", in_total, out_total,
              surface_checked ? "" : " (the model has no scene surface: no agreement curve)");
  for (const Sweep& sweep : sweeps) {
    std::printf("%s: lowest value with at most 5%% out-of-scene answers %.3f (configured %.3f)\n",
                sweep.name.c_str(), sweep.chosen, sweep.configured);
    for (const auto& point : sweep.curve)
      if (std::abs(point[sweep.name].get<double>() - sweep.configured) < 1e-6)
        std::printf("  at the configured value: %.1f%% correct, %.1f%% wrong, %.1f%% out-of-scene answered\n",
                    point["correct"].get<double>(), point["wrong"].get<double>(),
                    point["out_of_scene"].get<double>());
  }
  return 0;
}
