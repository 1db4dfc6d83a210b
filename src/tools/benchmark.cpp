// benchmark: per-stage latency of Relocalizer::relocalize on dataset frames,
// for several thread counts, and an optional speed-accuracy sweep over the
// number of sampled pixels and RANSAC hypotheses.

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli_support.h"
#include "relocalizer/core/progress.h"
#include "relocalizer/core/statistics.h"
#include "relocalizer/data/dataset.h"
#include "relocalizer/eval/metrics.h"
#include "relocalizer/eval/plot.h"
#include "relocalizer/pose/relocalizer.h"

using namespace relocalizer;

namespace {

struct Run {
  std::vector<StageTimings> timings;
  AccuracySummary accuracy;
};

Run runFrames(const Relocalizer& relocalizer, const std::vector<RgbdFrame>& frames, int repeat,
              const std::string& label) {
  Run run;
  std::vector<FrameError> errors;
  std::vector<std::optional<Pose>> estimates;
  std::vector<Pose> truths;
  // One untimed call: page in the model and warm TBB's workers.
  relocalizer.relocalize(frames.front());
  ProgressBar bar(label, frames.size() * repeat);
  for (int r = 0; r < repeat; ++r)
    for (const RgbdFrame& frame : frames) {
      const Relocalization result = relocalizer.relocalize(frame);
      run.timings.push_back(result.timings);
      if (r == 0 && frame.ground_truth) {
        std::optional<Pose> estimate;
        if (result.success) estimate = result.pose;
        errors.push_back(frameError(frame.id, estimate, *frame.ground_truth));
        estimates.push_back(estimate);
        truths.push_back(*frame.ground_truth);
      }
      bar.advance();
    }
  run.accuracy = summarizeAccuracy(errors, estimates, truths);
  return run;
}

nlohmann::json stageStats(const std::vector<StageTimings>& timings, double StageTimings::*stage) {
  std::vector<double> ms;
  for (const auto& t : timings) ms.push_back(1000.0 * (t.*stage));
  return {{"median_ms", median(ms)}, {"p95_ms", percentile(ms, 95)}};
}

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

std::vector<int> parseList(const std::string& text) {
  std::vector<int> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) values.push_back(std::stoi(item));
  return values;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Measures the latency of each relocalization stage (sampling: random pixels and LSD; "
      "forests: points and lines; preemptive RANSAC; Ceres refinement; whole call) on dataset "
      "frames for each thread count, prints medians and 95th percentiles, and writes them as "
      "JSON. --sweep also measures accuracy against latency over sampled pixels and hypotheses "
      "and draws the trade-off as a PNG.",
      "benchmark"};
  std::string model_path, dataset_path, frames, config, json_path, threads_text = "1,2", sweep_dir;
  int repeat = 1;
  app.add_option("-m,--model", model_path, "Model file written by train")->required();
  app.add_option("-d,--dataset", dataset_path, "Dataset folder")->required();
  app.add_option("--frames", frames, "Frame ids (default: all)");
  app.add_option("-c,--config", config, "YAML with a 'relocalizer:' section (default: compiled defaults)");
  app.add_option("--threads", threads_text, "Comma-separated thread counts")->capture_default_str();
  app.add_option("--repeat", repeat, "Passes over the frames")->check(CLI::Range(1, 100))->capture_default_str();
  app.add_option("--json", json_path, "Write the figures to this JSON file");
  app.add_option("--sweep", sweep_dir, "Run the speed-accuracy sweep (1 thread) into this folder");
  if (const int code = cli::parse(app, argc, argv); code >= 0) return code;

  std::vector<int> thread_counts;
  try {
    thread_counts = parseList(threads_text);
  } catch (const std::exception&) {
    return cli::fail(app, "--threads: expected comma-separated positive integers, got '" + threads_text + "'");
  }
  for (int t : thread_counts)
    if (t < 1) return cli::fail(app, "--threads: thread counts must be positive");

  RelocalizerParams params;
  if (!config.empty()) {
    auto loaded = loadRelocalizerParams(config);
    if (!loaded) return cli::fail(app, loaded.error());
    params = *loaded;
  }
  DatasetOptions options;
  options.frames = frames;
  auto dataset = openDataset(dataset_path, options);
  if (!dataset) return cli::fail(app, dataset.error());
  auto model = loadModel(model_path);
  if (!model) return cli::fail(app, model.error());

  std::vector<RgbdFrame> loaded;
  {
    ProgressBar bar("loading   ", (*dataset)->size());
    for (size_t i = 0; i < (*dataset)->size(); ++i) {
      auto frame = (*dataset)->load(i);
      if (!frame) return cli::fail(app, frame.error());
      loaded.push_back(std::move(*frame));
      bar.advance();
    }
  }
  const Relocalizer relocalizer(*model, params);
  if (const std::string why = relocalizer.validationError(); !why.empty()) return cli::fail(app, why);

  nlohmann::json out;
  out["cpu"] = cpuModel();
  out["frames"] = loaded.size();
  out["model"] = model_path;
  out["dataset"] = dataset_path;
  const std::pair<const char*, double StageTimings::*> stages[] = {
      {"sampling_points", &StageTimings::sampling_points},
      {"sampling_lines", &StageTimings::sampling_lines},
      {"forest_points", &StageTimings::forest_points},
      {"forest_lines", &StageTimings::forest_lines},
      {"ransac", &StageTimings::ransac},
      {"refinement", &StageTimings::refinement},
      {"surface", &StageTimings::surface},
      {"total", &StageTimings::total}};
  std::printf("CPU: %s; %zu frames x %d passes\n", out["cpu"].get<std::string>().c_str(),
              loaded.size(), repeat);
  std::printf("%-18s", "stage (ms)");
  for (int t : thread_counts) std::printf("  %d thread%s median / p95", t, t == 1 ? " " : "s");
  std::printf("\n");
  std::vector<Run> runs;
  for (int t : thread_counts) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, t);
    runs.push_back(runFrames(relocalizer, loaded, repeat, std::to_string(t) + " thread(s)"));
    nlohmann::json j;
    for (const auto& [name, member] : stages) j[name] = stageStats(runs.back().timings, member);
    j["within_5cm_5deg"] = runs.back().accuracy.within_5cm_5deg;
    out["threads"][std::to_string(t)] = j;
  }
  for (const auto& [name, member] : stages) {
    std::printf("%-18s", name);
    for (const Run& run : runs) {
      const nlohmann::json s = stageStats(run.timings, member);
      std::printf("  %14.1f / %-8.1f", s["median_ms"].get<double>(), s["p95_ms"].get<double>());
    }
    std::printf("\n");
  }
  std::printf("%-18s", "within 5cm/5deg");
  for (const Run& run : runs) std::printf("  %14.1f %%         ", 100 * run.accuracy.within_5cm_5deg);
  std::printf("\n");

  if (!sweep_dir.empty()) {
    std::filesystem::create_directories(sweep_dir);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    const std::vector<int> pixel_counts = {250, 500, 1000, 2000, 4000};
    const std::vector<int> hypothesis_counts = {64, 256, 1024};
    std::ofstream csv(sweep_dir + "/sweep.csv");
    csv << "point_samples,line_samples,hypotheses,median_ms,p95_ms,within_5cm_5deg,within_2cm_2deg,"
           "median_translation_cm,median_rotation_deg\n";
    Plot plot;
    plot.title = "speed vs accuracy, 1 thread (line samples = points / 2; dashed: 30 Hz, 50 ms)";
    plot.x_label = "median ms per frame";
    plot.y_label = "share of frames (%): 5 cm / 5 deg (lines), 2 cm / 2 deg (crosses)";
    int colour = 0;
    for (int hypotheses : hypothesis_counts) {
      PlotSeries series = PlotSeries::styled(std::to_string(hypotheses) + " hypotheses, 5 cm / 5 deg",
                                             plotColour(colour), true, 1);
      PlotSeries tight = PlotSeries::styled(std::to_string(hypotheses) + " hypotheses, 2 cm / 2 deg",
                                            plotColour(colour++), false, 2);
      for (int pixels : pixel_counts) {
        RelocalizerParams p = params;
        p.point_samples = pixels;
        p.line_samples = pixels / 2;
        p.solver.hypotheses = hypotheses;
        const Relocalizer variant(*model, p);
        const Run run = runFrames(variant, loaded, 1,
                                  "sweep " + std::to_string(pixels) + "/" + std::to_string(hypotheses));
        const nlohmann::json s = stageStats(run.timings, &StageTimings::total);
        csv << pixels << "," << pixels / 2 << "," << hypotheses << "," << s["median_ms"].get<double>()
            << "," << s["p95_ms"].get<double>() << "," << run.accuracy.within_5cm_5deg << ","
            << run.accuracy.within_2cm_2deg << "," << 100 * run.accuracy.median_translation_m << ","
            << run.accuracy.median_rotation_deg << "\n";
        tight.x.push_back(s["median_ms"].get<double>());
        tight.y.push_back(100 * run.accuracy.within_2cm_2deg);
        series.x.push_back(s["median_ms"].get<double>());
        series.y.push_back(100 * run.accuracy.within_5cm_5deg);
        const bool is_default = pixels == params.point_samples && hypotheses == params.solver.hypotheses;
        series.point_labels.push_back(std::to_string(pixels) + (is_default ? " (default)" : ""));
        out["sweep"].push_back({{"point_samples", pixels},
                                {"hypotheses", hypotheses},
                                {"median_ms", s["median_ms"]},
                                {"within_5cm_5deg", run.accuracy.within_5cm_5deg},
                                {"within_2cm_2deg", run.accuracy.within_2cm_2deg}});
      }
      plot.series.push_back(series);
      plot.series.push_back(tight);
    }
    // Room above the data for the legend (top right), none lost at the right
    // edge, and the two latency targets (50 ms, 30 Hz) as dashed lines.
    double most_ms = 0, least_share = 100, most_share = 0;
    for (const PlotSeries& s : plot.series) {
      for (double x : s.x) most_ms = std::max(most_ms, x);
      for (double y : s.y) least_share = std::min(least_share, y), most_share = std::max(most_share, y);
    }
    plot.x_min = 0;
    plot.x_max = 1.08 * most_ms;
    plot.y_min = std::floor(least_share) - 2;
    plot.y_max = most_share + 0.45 * (most_share - plot.y_min);
    plot.vertical_lines = {1000.0 / 30.0, 50.0};
    plot.save(sweep_dir + "/sweep.png", 1000, 650);
    std::printf("wrote %s/sweep.csv and %s/sweep.png\n", sweep_dir.c_str(), sweep_dir.c_str());
  }
  if (!json_path.empty()) {
    std::ofstream file(json_path);
    file << out.dump(2) << "\n";
    if (!file) return cli::fail(app, json_path + ": cannot write", 1);
  }
  return 0;
}
