// benchmark: per-stage latency of Relocalizer::relocalize on dataset frames,
// for several thread counts, and an optional speed-accuracy sweep over the
// number of sampled pixels and RANSAC hypotheses.

#include <fstream>
#include <sstream>

#include "cli_support.h"
#include "relocalizer/eval/latency_benchmark.h"
#include "relocalizer/relocalize/relocalizer.h"
#include "source_arguments.h"

using namespace relocalizer;

namespace {

Expected<std::vector<int>> parseThreadCounts(const std::string& text) {
  const auto wrong = [&] {
    return makeError("--threads: expected comma-separated positive integers, got '" + text + "'");
  };
  std::vector<int> values;
  std::stringstream in(text);
  std::string item;
  try {
    while (std::getline(in, item, ',')) values.push_back(std::stoi(item));
  } catch (const std::exception&) {
    return wrong();
  }
  for (int t : values)
    if (t < 1) return makeError("--threads: thread counts must be positive");
  return values;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Measures the latency of each relocalization stage (sampling: random pixels and LSD; "
      "forests: points and lines; preemptive RANSAC; Ceres refinement; whole call) on dataset "
      "frames for each thread count, prints medians and 95th percentiles, and writes them as "
      "JSON. --sweep also measures accuracy against latency over sampled pixels and hypotheses "
      "and draws the trade-off as a PNG.",
      "benchmark"};
  std::string model_path, config, json_path, threads_text = "1,2", sweep_dir;
  int repeat = 1;
  cli::SourceOptions source_options;
  app.addOption("-m,--model", model_path, "Model file written by train")->required();
  source_options.add(app, "Dataset folder", "Frame ids (default: all)");
  app.addOption("-c,--config", config,
                "YAML with a 'relocalizer:' section (default: compiled defaults)");
  app.addOption("--threads", threads_text, "Comma-separated thread counts")->showDefault();
  app.addOption("--repeat", repeat, "Passes over the frames")->range(1, 100)->showDefault();
  app.addOption("--json", json_path, "Write the figures to this JSON file");
  app.addOption("--sweep", sweep_dir, "Run the speed-accuracy sweep (1 thread) into this folder");
  if (const cli::Exit done = app.parse(argc, argv)) return *done;

  auto thread_counts = parseThreadCounts(threads_text);
  if (!thread_counts) return cli::fail(app, thread_counts.error());
  RelocalizerParams params;
  if (!config.empty()) {
    auto loaded = loadRelocalizerParams(config);
    if (!loaded) return cli::fail(app, loaded.error());
    params = *loaded;
  }
  auto source = source_options.open();
  if (!source) return cli::fail(app, source.error());
  auto model = loadModel(model_path);
  if (!model) return cli::fail(app, model.error());
  auto frames = loadAllFrames(**source);
  if (!frames) return cli::fail(app, frames.error());
  if (frames->empty()) return cli::fail(app, (*source)->path() + ": no frame selected");
  const Relocalizer relocalizer(*model, params);
  if (const std::string why = relocalizer.validationError(); !why.empty())
    return cli::fail(app, why);

  nlohmann::json out;
  out["cpu"] = cpuModel();
  out["frames"] = frames->size();
  out["model"] = model_path;
  out["dataset"] = (*source)->path();
  std::printf("CPU: %s; %zu frames x %d passes\n", out["cpu"].get<std::string>().c_str(),
              frames->size(), repeat);
  std::printf("%s", formatStageTableHead(*thread_counts).c_str());
  const std::vector<TimedRun> runs = timeThreadCounts(relocalizer, *frames, *thread_counts, repeat);
  out["threads"] = timedRunsJson(runs);
  std::printf("%s", formatStageTableRows(runs).c_str());

  if (!sweep_dir.empty()) {
    auto sweep = speedAccuracySweep(*model, params, *frames, sweep_dir);
    if (!sweep) return cli::fail(app, sweep.error(), 1);
    out["sweep"] = *sweep;
    std::printf("wrote %s/sweep.csv and %s/sweep.png\n", sweep_dir.c_str(), sweep_dir.c_str());
  }
  if (!json_path.empty()) {
    std::ofstream file(json_path);
    file << out.dump(2) << "\n";
    if (!file) return cli::fail(app, json_path + ": cannot write", 1);
  }
  return 0;
}
