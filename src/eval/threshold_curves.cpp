#include "relocalizer/eval/threshold_curves.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>

#include "relocalizer/core/progress.h"
#include "relocalizer/eval/metrics.h"
#include "relocalizer/eval/plot.h"

namespace relocalizer {

namespace {

// One sweep per "no pose" gate, the other gates at their configured values:
// the share of frames each threshold lets through.
struct Sweep {
  std::string name, file, label;
  float configured;
  std::function<bool(const GateAnswer&, float)> accepts;
  double chosen = -1;  // lowest threshold with at most 5 % out-of-scene answers
  nlohmann::json curve = nlohmann::json::array();
};

std::vector<Sweep> sweepsFor(const std::vector<GateAnswer>& answers, const GateSettings& c) {
  std::vector<Sweep> sweeps;
  sweeps.push_back({"min_inlier_ratio", "curves",
                    "min_inlier_ratio (share of samples that are inliers)", c.min_inlier_ratio,
                    [c](const GateAnswer& a, float t) {
                      return a.score >= t && a.inliers >= c.min_inliers &&
                             (a.agreement < 0 || a.agreement >= c.min_agreement);
                    }});
  const bool surface_checked = std::any_of(answers.begin(), answers.end(),
                                           [](const GateAnswer& a) { return a.agreement >= 0; });
  if (surface_checked)
    sweeps.push_back(
        {"min_agreement", "agreement_curves",
         "surface.min_agreement (share of the depth not in front of the surface that lies on it)",
         c.min_agreement, [c](const GateAnswer& a, float t) {
           return a.score >= c.min_inlier_ratio && a.inliers >= c.min_inliers && a.agreement >= t;
         }});
  return sweeps;
}

// Sweeps one gate from 0 to its top in 120 steps; writes its CSV and PNG.
void runSweep(Sweep& sweep, const std::vector<GateAnswer>& answers, int in_total, int out_total,
              const std::string& folder) {
  std::ofstream csv(folder + "/" + sweep.file + ".csv");
  csv << sweep.name << ",in_scene_correct,in_scene_wrong,out_of_scene_answered\n";
  auto correct = PlotSeries::styled("in-scene, correct pose", plotColour(2), true, 0);
  auto wrong = PlotSeries::styled("in-scene, wrong pose", plotColour(3), true, 0);
  auto outside_answered =
      PlotSeries::styled("other scenes, any pose (false relocalization)", plotColour(4), true, 0);
  const float top = sweep.name == "min_agreement" ? 1.0f : 0.6f;
  for (int step = 0; step <= 120; ++step) {
    const float threshold = top * step / 120.0f;
    int c = 0, w = 0, o = 0;
    for (const GateAnswer& a : answers) {
      if (!a.has_pose || !sweep.accepts(a, threshold)) continue;
      if (!a.in_scene)
        ++o;
      else if (a.correct)
        ++c;
      else
        ++w;
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
    sweep.curve.push_back(
        {{sweep.name, threshold}, {"correct", cs}, {"wrong", ws}, {"out_of_scene", os}});
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
  plot.save(folder + "/" + sweep.file + ".png", 1000, 600);
}

std::string report(const std::vector<Sweep>& sweeps, int in_total, int out_total) {
  std::string text;
  char line[512];
  std::snprintf(line, sizeof line, "%d in-scene and %d out-of-scene frames%s\n", in_total,
                out_total,
                sweeps.size() > 1 ? "" : " (the model has no scene surface: no agreement curve)");
  text += line;
  for (const Sweep& sweep : sweeps) {
    std::snprintf(line, sizeof line,
                  "%s: lowest value with at most 5%% out-of-scene answers %.3f (configured %.3f)\n",
                  sweep.name.c_str(), sweep.chosen, sweep.configured);
    text += line;
    for (const auto& point : sweep.curve)
      if (std::abs(point[sweep.name].get<double>() - sweep.configured) < 1e-6) {
        std::snprintf(
            line, sizeof line,
            "  at the configured value: %.1f%% correct, %.1f%% wrong, %.1f%% out-of-scene "
            "answered\n",
            point["correct"].get<double>(), point["wrong"].get<double>(),
            point["out_of_scene"].get<double>());
        text += line;
      }
  }
  return text;
}

}  // namespace

GateSettings gateSettings(const RelocalizerParams& params) {
  return {params.solver.min_inliers, params.solver.min_inlier_ratio, params.surface.min_agreement};
}

RelocalizerParams withGatesOpen(RelocalizerParams params) {
  params.solver.min_inliers = 0;
  params.solver.min_inlier_ratio = 0.0f;
  params.surface.min_agreement = 0.0f;
  return params;
}

Expected<std::vector<GateAnswer>> answerFrames(const Relocalizer& relocalizer,
                                               const FrameSource& source, bool in_scene) {
  std::vector<GateAnswer> answers;
  ProgressBar bar(in_scene ? "in-scene    " : "out-of-scene", source.size());
  for (size_t i = 0; i < source.size(); ++i) {
    bar.advance();
    auto frame = source.load(i);
    if (!frame) return makeError(frame.error());
    const Relocalization r = relocalizer.relocalize(*frame);
    GateAnswer a;
    a.in_scene = in_scene;
    a.has_pose = r.success;
    a.inliers = r.point_inliers + r.line_inliers;
    a.score = r.score;
    a.agreement = r.surface_agreement;
    if (in_scene && r.success && frame->ground_truth)
      a.correct = within(frameError(frame->id, r.pose, *frame->ground_truth), kCorrectPose);
    answers.push_back(a);
  }
  return answers;
}

Expected<std::string> writeThresholdCurves(const std::vector<GateAnswer>& answers,
                                           const GateSettings& configured,
                                           const std::string& folder,
                                           const std::string& extra_json) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec) return makeError(folder + ": cannot create output folder: " + ec.message());
  int in_total = 0, out_total = 0;
  for (const GateAnswer& a : answers) (a.in_scene ? in_total : out_total)++;
  std::vector<Sweep> sweeps = sweepsFor(answers, configured);
  nlohmann::json j;
  for (Sweep& sweep : sweeps) {
    runSweep(sweep, answers, in_total, out_total, folder);
    j[sweep.name] = {{"configured", sweep.configured},
                     {"lowest_with_at_most_5pct_false", sweep.chosen},
                     {"curve", sweep.curve}};
  }
  try {
    j.update(nlohmann::json::parse(extra_json));
  } catch (const std::exception& e) {
    return makeError(std::string("curves.json extra fields are not valid JSON: ") + e.what());
  }
  j["in_scene_frames"] = in_total;
  j["out_of_scene_frames"] = out_total;
  j["configured_min_inliers"] = configured.min_inliers;
  std::ofstream out(folder + "/curves.json");
  out << j.dump(2) << "\n";
  if (!out) return makeError(folder + "/curves.json: cannot write");
  return report(sweeps, in_total, out_total);
}

}  // namespace relocalizer
